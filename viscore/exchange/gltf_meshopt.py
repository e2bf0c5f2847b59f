"""GLB geometry compressed with ``EXT_meshopt_compression``, decoded to a plain GLB.

Decodes the buffer views of the extension [1]_ and the normalized positions of
``KHR_mesh_quantization`` [2]_ (glTF 2.0, sec. 3.11), so that trimesh reads the file.

References
----------
.. [1] The Khronos Group. "EXT_meshopt_compression", glTF extension registry.
   https://github.com/KhronosGroup/glTF/tree/main/extensions/2.0/Vendor/EXT_meshopt_compression
.. [2] The Khronos Group. "KHR_mesh_quantization", glTF extension registry.
"""

from __future__ import annotations

import struct

import numpy as np

from .._validate import InputError

__all__ = ["decode_meshopt_glb", "EXTENSION", "MAX_DECODED"]

#: The extension this module decodes.
EXTENSION = "EXT_meshopt_compression"

_HEADER = struct.Struct("<4sII")
_CHUNK = struct.Struct("<I4s")
_BIN = b"BIN\0"
#: Bytes between decoded views in the new binary chunk (meshopt's filters want 4; 16
#: keeps every SIMD-friendly reader happy).
_ALIGN = 16
#: Component types of glTF accessors: (numpy dtype, divisor of a normalized value).
_NORMALIZED = {5120: (np.int8, 127.0), 5121: (np.uint8, 255.0),
               5122: (np.int16, 32767.0), 5123: (np.uint16, 65535.0)}
#: The high nibble of the first byte of each mode's bitstream (the codec's header; the
#: low nibble is its version), checked before any output is allocated.
_MAGIC = {"ATTRIBUTES": 0xA0, "TRIANGLES": 0xE0, "INDICES": 0xD0}
#: The most bytes one compressed byte can decode to, per mode, with room to spare: the
#: vertex codec's version 1 packs a block of zero channels into two bits (about 1,000
#: to 1 measured on zeros); the index codecs spend at least one byte per triangle
#: (12 bytes of 32-bit indices) or per index (4 bytes).
_RATIO = {"ATTRIBUTES": 4096, "TRIANGLES": 16, "INDICES": 8}
#: Decoded bytes (512 MiB) a file may ask for in all, so that a few hundred bytes of JSON cannot
#: make the reader allocate gigabytes.
MAX_DECODED = 1 << 29


def _int(value: object, what: str, label: str, *, low: int = 0,
         prefix: str = EXTENSION) -> int:
    if type(value) is not int or value < low:
        raise InputError(f"{label}: {prefix}: {what} must be an integer >= {low}, "
                         f"got {value!r}")
    return value


def _decode_view(ext: dict, blob: memoryview, label: str, index: int, room: int
                 ) -> np.ndarray:
    """The decoded bytes of one compressed buffer view (``count * byteStride`` bytes),
    refused when they would pass ``room`` bytes."""
    import meshoptimizer

    where = f"bufferView {index}"
    offset = _int(ext.get("byteOffset", 0), f"{where} byteOffset", label)
    length = _int(ext.get("byteLength"), f"{where} byteLength", label, low=1)
    stride = _int(ext.get("byteStride"), f"{where} byteStride", label, low=1)
    count = _int(ext.get("count"), f"{where} count", label)
    mode, filt = ext.get("mode"), ext.get("filter", "NONE")
    if not isinstance(mode, str) or mode not in _MAGIC:
        raise InputError(f"{label}: {EXTENSION}: {where} has an unknown mode {mode!r}")
    filters = {"NONE": None, "OCTAHEDRAL": meshoptimizer.decode_filter_oct,
               "QUATERNION": meshoptimizer.decode_filter_quat,
               "EXPONENTIAL": meshoptimizer.decode_filter_exp}
    if not isinstance(filt, str) or filt not in filters:
        raise InputError(f"{label}: {EXTENSION}: {where} has an unknown filter {filt!r}")
    if mode != "ATTRIBUTES" and filt != "NONE":
        raise InputError(f"{label}: {EXTENSION}: {where}: filter {filt} is for ATTRIBUTES, "
                         f"not {mode}")
    strides = {"OCTAHEDRAL": (4, 8), "QUATERNION": (8,)}  # the extension's rules
    if filt in strides and stride not in strides[filt]:
        raise InputError(f"{label}: {EXTENSION}: {where}: filter {filt} needs byteStride "
                         f"{' or '.join(map(str, strides[filt]))}, got {stride}")
    if mode == "ATTRIBUTES" and (stride % 4 or stride > 256):
        raise InputError(f"{label}: {EXTENSION}: {where}: ATTRIBUTES byteStride must be a "
                         f"multiple of 4 up to 256, got {stride}")
    if mode != "ATTRIBUTES" and stride not in (2, 4):
        raise InputError(f"{label}: {EXTENSION}: {where}: index byteStride must be 2 or 4, "
                         f"got {stride}")
    if mode == "TRIANGLES" and count % 3:
        raise InputError(f"{label}: {EXTENSION}: {where}: TRIANGLES count {count} is not a "
                         "multiple of 3")
    if offset + length > len(blob):
        raise InputError(f"{label}: {EXTENSION}: {where} reads {length:,} bytes at "
                         f"{offset:,}, past the binary chunk's {len(blob):,}")
    if blob[offset] & 0xF0 != _MAGIC[mode]:
        raise InputError(f"{label}: {EXTENSION}: {where} does not start with the {mode} "
                         f"codec's header (byte 0x{blob[offset]:02x})")
    size = count * stride
    if size > _RATIO[mode] * length + 4096:
        raise InputError(f"{label}: {EXTENSION}: {where} claims {size:,} bytes from "
                         f"{length:,}, more than the {mode} codec can give")
    if size > room:
        raise InputError(f"{label}: {EXTENSION}: the compressed views decode to more than "
                         f"{MAX_DECODED / 2**20:,.0f} MiB in all (limit "
                         "viscore.exchange.gltf_meshopt.MAX_DECODED)")
    data = bytes(blob[offset:offset + length])
    try:
        if mode == "ATTRIBUTES":
            out = meshoptimizer.decode_vertex_buffer(count, stride, data).view(np.uint8)
            out = out.reshape(-1)
            if filters[filt] is not None:
                out = filters[filt](out, count, stride)
        else:
            decode = (meshoptimizer.decode_index_buffer if mode == "TRIANGLES"
                      else meshoptimizer.decode_index_sequence)
            # the decoder writes `stride` bytes per index at the start of its array
            out = np.ascontiguousarray(decode(count, stride, data)).view(np.uint8)
            out = out.reshape(-1)[:size]
    except (ValueError, RuntimeError) as exc:
        raise InputError(f"{label}: {EXTENSION}: {where} does not decode "
                         f"({' '.join(str(exc).split())[:120]})") from None
    raw = np.ascontiguousarray(out, dtype=np.uint8)
    if raw.nbytes != size:  # pragma: no cover - the decoders size their output
        raise InputError(f"{label}: {EXTENSION}: {where} decoded to {raw.nbytes:,} bytes, "
                         f"not {size:,}")
    return raw


def _chunks(data: bytes, end: int, label: str) -> tuple[memoryview, int]:
    """The binary chunk after the JSON chunk (which ends at ``end``), and where it ends."""
    if end + _CHUNK.size > len(data):
        raise InputError(f"{label}: the file has no binary chunk, which its "
                         "compressed or quantized data needs")
    length, kind = _CHUNK.unpack_from(data, end)
    start = end + _CHUNK.size
    if kind != _BIN or start + length > len(data):
        raise InputError(f"{label}: the file's second chunk is not a complete binary chunk")
    return memoryview(data)[start:start + length], start + length


def _pad(buf: bytearray, align: int = _ALIGN) -> None:
    buf.extend(b"\0" * (-len(buf) % align))


def _list(value: object) -> list:
    return value if isinstance(value, list) else []


def _dict(value: object) -> dict:
    return value if isinstance(value, dict) else {}


def _normalized_positions(header: dict) -> list[int]:
    """Indices of the normalized integer ``POSITION`` accessors of the meshes (any part
    of the JSON of another shape is skipped: this runs on every GLB, and the reader
    after it says what is wrong)."""
    accessors = _list(header.get("accessors"))
    found: list[int] = []
    for mesh in _list(header.get("meshes")):
        for prim in _list(_dict(mesh).get("primitives")):
            index = _dict(_dict(prim).get("attributes")).get("POSITION")
            if type(index) is not int or not 0 <= index < len(accessors) or index in found:
                continue
            acc = _dict(accessors[index])
            kind = acc.get("componentType")
            if (acc.get("normalized") is True and type(kind) is int
                    and kind in _NORMALIZED and "bufferView" in acc):
                found.append(index)
    return found


_QUANT = "KHR_mesh_quantization"


def _position_rows(header: dict, raw: memoryview, index: int, label: str) -> np.ndarray:
    """One normalized integer ``POSITION`` accessor read as float32 rows."""
    acc, views = header["accessors"][index], _list(header.get("bufferViews"))
    where = f"normalized POSITION accessor {index}"
    if acc.get("type") != "VEC3":
        raise InputError(f"{label}: {_QUANT}: {where} has type {acc.get('type')!r}, "
                         "not VEC3")
    if "sparse" in acc:
        raise InputError(f"{label}: {_QUANT}: {where} is sparse, which is not read")
    dtype, scale = _NORMALIZED[acc["componentType"]]
    view_index = _int(acc["bufferView"], f"{where} bufferView", label, prefix=_QUANT)
    view = views[view_index] if view_index < len(views) else None
    if not isinstance(view, dict) or view.get("buffer") != 0 \
            or type(view.get("buffer")) is not int:
        raise InputError(f"{label}: {_QUANT}: {where} is not in the GLB's binary chunk "
                         "(only that is read)")
    count = _int(acc.get("count"), f"{where} count", label, prefix=_QUANT)
    size = np.dtype(dtype).itemsize
    stride = _int(view.get("byteStride", 3 * size), f"bufferView {view_index} byteStride",
                  label, low=3 * size, prefix=_QUANT)
    first = _int(view.get("byteOffset", 0), f"bufferView {view_index} byteOffset", label,
                 prefix=_QUANT)
    length = _int(view.get("byteLength"), f"bufferView {view_index} byteLength", label,
                  prefix=_QUANT)
    start = _int(acc.get("byteOffset", 0), f"{where} byteOffset", label, prefix=_QUANT)
    if first + length > len(raw) or (count and start + (count - 1) * stride + 3 * size
                                     > length):
        raise InputError(f"{label}: {_QUANT}: {where} reads past its buffer view or the "
                         "binary chunk")
    if not count:
        return np.zeros((0, 3), "<f4")
    rows = np.lib.stride_tricks.as_strided(
        np.frombuffer(raw, dtype=np.uint8, count=length, offset=first + start),
        shape=(count, 3 * size), strides=(stride, 1))
    values = np.ascontiguousarray(rows).view(dtype).reshape(count, 3)
    return np.maximum(values / scale, -1.0).astype("<f4")


def _dequantize_positions(header: dict, bin_: bytearray, found: list[int], label: str
                          ) -> None:
    """The normalized integer ``POSITION`` accessors ``found`` rewritten as float32
    (module docstring)."""
    if not found:
        return
    raw = memoryview(bytes(bin_))
    converted = [(index, _position_rows(header, raw, index, label)) for index in found]
    views = header["bufferViews"]
    for index, floats in converted:
        _pad(bin_)
        views.append({"buffer": 0, "byteOffset": len(bin_), "byteLength": floats.nbytes})
        bin_.extend(floats.tobytes())
        acc = header["accessors"][index]
        acc.update(bufferView=len(views) - 1, byteOffset=0, componentType=5126,
                   normalized=False)
        if len(floats):
            acc["min"], acc["max"] = floats.min(0).tolist(), floats.max(0).tolist()


def _is_fallback(buffer: dict) -> bool:
    ext = _dict(buffer.get("extensions")).get(EXTENSION)
    return isinstance(ext, dict) and ext.get("fallback") is True


def decode_meshopt_glb(data: bytes, header: dict, end: int, label: str
                       ) -> tuple[bytes, dict]:
    """A plain GLB of a GLB whose buffer views use ``EXT_meshopt_compression`` or whose
    positions are normalized integers.

    Parameters
    ----------
    data : bytes
        The GLB file.
    header : dict
        Its JSON chunk, parsed; not changed.
    end : int
        Offset where the JSON chunk ends (the binary chunk's header follows).
    label : str
        The file's name in messages.

    Returns
    -------
    data, header
        The new GLB's bytes (JSON chunk, then one binary chunk: the old one and the
        decoded views and float32 positions after it) and its JSON. Files with
        neither come back as they are.

    Raises
    ------
    InputError
        A compressed view whose source is not the binary chunk, an unknown mode or
        filter, counts or offsets beyond the data, or bytes that do not decode.
    """
    views = header.get("bufferViews")
    buffers = header.get("buffers")
    if views is not None and not (isinstance(views, list)
                                  and all(isinstance(v, dict) for v in views)):
        raise InputError(f"{label}: not a valid GLB file (bufferViews must be a list of "
                         "objects)")
    for i, view in enumerate(views or []):
        if not isinstance(view.get("extensions", {}), dict):
            raise InputError(f"{label}: not a valid GLB file (bufferView {i}'s extensions "
                             "must be an object)")
    used = [EXTENSION in (v.get("extensions") or {}) for v in views or []]
    positions = _normalized_positions(header)
    if not any(used) and not positions:
        return data, header
    if buffers is not None and not (isinstance(buffers, list)
                                    and all(isinstance(b, dict) for b in buffers)):
        raise InputError(f"{label}: not a valid GLB file (buffers must be a list of objects)")
    buffers = buffers or []
    if views and not buffers:
        raise InputError(f"{label}: not a valid GLB file (it has buffer views but no "
                         "buffers)")
    inside = bool(buffers) and "uri" not in buffers[0] and not _is_fallback(buffers[0])
    if not any(used) and not inside:
        return data, header  # positions in an external buffer: left to the reader
    if not inside:
        raise InputError(f"{label}: {EXTENSION}: the compressed data must lie in the GLB's "
                         "binary chunk (buffer 0, without a URI, not a fallback)")
    blob, _ = _chunks(data, end, label)
    fallback = [_is_fallback(b) for b in buffers]
    keep = [i for i, f in enumerate(fallback) if not f]
    renumber = {old: new for new, old in enumerate(keep)}
    out = dict(header)
    bin_ = bytearray(blob)
    new_views, decoded = [], 0
    for i, view in enumerate(views or []):
        view = dict(view)
        if used[i]:
            ext = view["extensions"][EXTENSION]
            if not isinstance(ext, dict) or type(ext.get("buffer")) is not int \
                    or ext["buffer"] != 0:
                raise InputError(f"{label}: {EXTENSION}: bufferView {i}'s compressed data "
                                 "is not in the GLB's binary chunk (only that is decoded)")
            raw = _decode_view(ext, blob, label, i, MAX_DECODED - decoded)
            decoded += raw.nbytes
            if ext["mode"] == "ATTRIBUTES":
                if view.get("byteStride", ext["byteStride"]) != ext["byteStride"]:
                    raise InputError(
                        f"{label}: {EXTENSION}: bufferView {i} has byteStride "
                        f"{view['byteStride']!r} but its compressed data "
                        f"{ext['byteStride']}")
            else:
                view.pop("byteStride", None)
            _pad(bin_)
            view.update(buffer=0, byteOffset=len(bin_), byteLength=raw.nbytes)
            bin_.extend(raw.data)
            del raw
            rest = {k: v for k, v in view["extensions"].items() if k != EXTENSION}
            if rest:
                view["extensions"] = rest
            else:
                del view["extensions"]
        else:
            index = view.get("buffer")
            if type(index) is not int or not 0 <= index < len(buffers):
                raise InputError(f"{label}: not a valid GLB file (bufferView {i} names no "
                                 f"buffer: {index!r})")
            if fallback[index]:
                raise InputError(f"{label}: bufferView {i} reads a meshopt fallback "
                                 "buffer, which holds no data")
            view["buffer"] = renumber[index]
        new_views.append(view)
    out["bufferViews"] = new_views
    out["accessors"] = [dict(a) if isinstance(a, dict) else a
                        for a in _list(header.get("accessors"))]
    _dequantize_positions(out, bin_, positions, label)
    _pad(bin_, 4)
    out["buffers"] = [dict(buffers[i]) for i in keep]
    out["buffers"][0]["byteLength"] = len(bin_)
    for key in ("extensionsUsed", "extensionsRequired"):
        if isinstance(header.get(key), list):
            names = [n for n in header[key] if n != EXTENSION]
            if names:
                out[key] = names
            else:
                out.pop(key, None)
    import json

    text = json.dumps(out).encode("utf-8")
    text += b" " * (-len(text) % 4)
    total = _HEADER.size + 2 * _CHUNK.size + len(text) + len(bin_)
    body = b"".join([_HEADER.pack(b"glTF", 2, total), _CHUNK.pack(len(text), b"JSON"), text,
                     _CHUNK.pack(len(bin_), _BIN), bin_])
    return body, out
