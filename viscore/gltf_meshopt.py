"""GLB geometry compressed with ``EXT_meshopt_compression``, decoded to a plain GLB.

gltfpack and gltf-transform write web-ready levels whose buffer views hold
meshoptimizer's vertex and index codecs (the extension [1]_: each compressed
view names its source ``buffer``, ``byteOffset``, ``byteLength``,
``byteStride``, ``count``, ``mode`` ``ATTRIBUTES``, ``TRIANGLES`` or
``INDICES``, and ``filter`` ``NONE``, ``OCTAHEDRAL``, ``QUATERNION`` or
``EXPONENTIAL``; the view's own buffer is a *fallback* buffer that holds no
bytes). trimesh's reader cannot decode them. :func:`decode_meshopt_glb`
decodes every compressed view with the ``meshoptimizer`` package (already a
dependency, for the ``godot`` baseline), appends the decoded bytes to the
GLB's binary chunk, points the views there, drops the fallback buffers and the
extension, and returns a GLB that any reader takes as it is.

Such files usually quantize their vertices too (``KHR_mesh_quantization``
[2]_): integer positions scaled back by the node's transform, which trimesh
reads as it is; a ``normalized`` integer ``POSITION`` accessor, which trimesh
would read unscaled, is converted here to float32 by the glTF 2.0 rules
(sec. 3.11: ``c / 127``, ``c / 255``, ``c / 32767``, ``c / 65535``, signed
values clamped at -1).

Only compressed data in the GLB's own binary chunk is decoded; a compressed
view whose source is an external buffer is refused with one line.

References
----------
.. [1] The Khronos Group. "EXT_meshopt_compression", glTF extension registry.
   https://github.com/KhronosGroup/glTF/tree/main/extensions/2.0/Vendor/EXT_meshopt_compression
.. [2] The Khronos Group. "KHR_mesh_quantization", glTF extension registry.
"""

from __future__ import annotations

import struct

import numpy as np

from ._validate import InputError

__all__ = ["decode_meshopt_glb", "EXTENSION"]

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


def _int(value: object, what: str, label: str, *, low: int = 0) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise InputError(f"{label}: {EXTENSION}: {what} must be an integer >= {low}, "
                         f"got {value!r}")
    return value


def _decode_view(ext: dict, blob: memoryview, label: str, index: int) -> bytes:
    """The decoded bytes of one compressed buffer view (``count * byteStride`` bytes)."""
    import meshoptimizer

    where = f"bufferView {index}"
    offset = _int(ext.get("byteOffset", 0), f"{where} byteOffset", label)
    length = _int(ext.get("byteLength"), f"{where} byteLength", label)
    stride = _int(ext.get("byteStride"), f"{where} byteStride", label, low=1)
    count = _int(ext.get("count"), f"{where} count", label)
    mode, filt = ext.get("mode"), ext.get("filter", "NONE")
    if offset + length > len(blob):
        raise InputError(f"{label}: {EXTENSION}: {where} reads {length:,} bytes at "
                         f"{offset:,}, past the binary chunk's {len(blob):,}")
    data = bytes(blob[offset:offset + length])
    filters = {"NONE": None, "OCTAHEDRAL": meshoptimizer.decode_filter_oct,
               "QUATERNION": meshoptimizer.decode_filter_quat,
               "EXPONENTIAL": meshoptimizer.decode_filter_exp}
    if mode not in ("ATTRIBUTES", "TRIANGLES", "INDICES"):
        raise InputError(f"{label}: {EXTENSION}: {where} has an unknown mode {mode!r}")
    if mode == "ATTRIBUTES" and filt not in filters:
        raise InputError(f"{label}: {EXTENSION}: {where} has an unknown filter {filt!r}")
    strides = {"OCTAHEDRAL": (4, 8), "QUATERNION": (8,)}  # the extension's rules
    if mode == "ATTRIBUTES" and filt in strides and stride not in strides[filt]:
        raise InputError(f"{label}: {EXTENSION}: {where}: filter {filt} needs byteStride "
                         f"{' or '.join(map(str, strides[filt]))}, got {stride}")
    if mode != "ATTRIBUTES" and stride not in (2, 4):
        raise InputError(f"{label}: {EXTENSION}: {where}: index byteStride must be 2 or 4, "
                         f"got {stride}")
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
            out = np.frombuffer(decode(count, stride, data).tobytes()[:count * stride],
                                dtype=np.uint8)
    except (ValueError, RuntimeError) as exc:
        raise InputError(f"{label}: {EXTENSION}: {where} does not decode "
                         f"({' '.join(str(exc).split())[:120]})") from None
    raw = np.ascontiguousarray(out).tobytes()
    if len(raw) != count * stride:  # pragma: no cover - the decoders size their output
        raise InputError(f"{label}: {EXTENSION}: {where} decoded to {len(raw):,} bytes, "
                         f"not {count * stride:,}")
    return raw


def _chunks(data: bytes, end: int, label: str) -> tuple[memoryview, int]:
    """The binary chunk after the JSON chunk (which ends at ``end``), and where it ends."""
    if end + _CHUNK.size > len(data):
        raise InputError(f"{label}: {EXTENSION} is required but the file has no binary chunk")
    length, kind = _CHUNK.unpack_from(data, end)
    start = end + _CHUNK.size
    if kind != _BIN or start + length > len(data):
        raise InputError(f"{label}: {EXTENSION} is required but the file's second chunk is "
                         "not a complete binary chunk")
    return memoryview(data)[start:start + length], start + length


def _pad(buf: bytearray, align: int = _ALIGN) -> None:
    buf.extend(b"\0" * (-len(buf) % align))


def _normalized_positions(header: dict) -> list[int]:
    """Indices of the normalized integer ``POSITION`` accessors of the meshes."""
    accessors = header.get("accessors")
    found: list[int] = []
    for mesh in header.get("meshes") or []:
        for prim in (mesh.get("primitives") or []) if isinstance(mesh, dict) else []:
            index = (prim.get("attributes") or {}).get("POSITION") if isinstance(
                prim, dict) else None
            if (isinstance(index, int) and isinstance(accessors, list)
                    and 0 <= index < len(accessors) and index not in found
                    and isinstance(accessors[index], dict)
                    and accessors[index].get("normalized") is True
                    and accessors[index].get("componentType") in _NORMALIZED
                    and "bufferView" in accessors[index]):
                found.append(index)
    return found


def _dequantize_positions(header: dict, bin_: bytearray, label: str) -> None:
    """Normalized integer ``POSITION`` accessors rewritten as float32 (module docstring)."""
    accessors, views = header["accessors"], header["bufferViews"]
    raw = np.frombuffer(bytes(bin_), dtype=np.uint8)
    converted = []
    for index in _normalized_positions(header):
        acc = accessors[index]
        dtype, scale = _NORMALIZED[acc["componentType"]]
        view_index = _int(acc["bufferView"], f"accessor {index} bufferView", label)
        if view_index >= len(views) or views[view_index].get("buffer") != 0:
            raise InputError(f"{label}: normalized POSITION accessor {index} is not in the "
                             "GLB's binary chunk (only that is read)")
        view = views[view_index]
        count = _int(acc.get("count"), f"accessor {index} count", label)
        size = np.dtype(dtype).itemsize
        stride = _int(view.get("byteStride", 3 * size), f"bufferView {view_index} byteStride",
                      label, low=1)
        start = _int(view.get("byteOffset", 0), f"bufferView {view_index} byteOffset", label) \
            + _int(acc.get("byteOffset", 0), f"accessor {index} byteOffset", label)
        if count and start + (count - 1) * stride + 3 * size > len(raw):
            raise InputError(f"{label}: accessor {index} reads past the binary chunk")
        rows = np.lib.stride_tricks.as_strided(raw[start:], shape=(count, 3 * size),
                                               strides=(stride, 1))
        values = np.ascontiguousarray(rows).view(dtype).reshape(count, 3)
        converted.append((index, np.maximum(values / scale, -1.0).astype("<f4")))
    for index, floats in converted:
        _pad(bin_)
        views.append({"buffer": 0, "byteOffset": len(bin_), "byteLength": floats.nbytes})
        bin_.extend(floats.tobytes())
        acc = accessors[index]
        acc.update(bufferView=len(views) - 1, byteOffset=0, componentType=5126,
                   normalized=False)
        if len(floats):
            acc["min"], acc["max"] = floats.min(0).tolist(), floats.max(0).tolist()


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
    if not any(used) and not _normalized_positions(header):
        return data, header
    inside = isinstance(buffers, list) and buffers and isinstance(buffers[0], dict) \
        and "uri" not in buffers[0]
    if not any(used) and not inside:
        return data, header  # positions in an external buffer: left to the reader
    if not inside:
        raise InputError(f"{label}: {EXTENSION}: the compressed data must lie in the GLB's "
                         "binary chunk (buffer 0 without a URI)")
    blob, _ = _chunks(data, end, label)
    fallback = [isinstance(b, dict) and bool(((b.get("extensions") or {}).get(EXTENSION)
                                              or {}).get("fallback")) for b in buffers]
    keep = [i for i, f in enumerate(fallback) if not f]
    renumber = {old: new for new, old in enumerate(keep)}
    out = dict(header)
    bin_ = bytearray(blob)
    new_views = []
    for i, view in enumerate(views):
        view = dict(view)
        if used[i]:
            ext = view["extensions"][EXTENSION]
            if not isinstance(ext, dict) or ext.get("buffer", None) not in renumber or \
                    renumber[ext["buffer"]] != 0:
                raise InputError(f"{label}: {EXTENSION}: bufferView {i}'s compressed data "
                                 "is not in the GLB's binary chunk (only that is decoded)")
            raw = _decode_view(ext, blob, label, i)
            _pad(bin_)
            view.update(buffer=0, byteOffset=len(bin_), byteLength=len(raw))
            if ext["mode"] == "ATTRIBUTES":
                view["byteStride"] = ext["byteStride"]
            else:
                view.pop("byteStride", None)
            bin_.extend(raw)
            rest = {k: v for k, v in view["extensions"].items() if k != EXTENSION}
            if rest:
                view["extensions"] = rest
            else:
                del view["extensions"]
        elif view.get("buffer") not in renumber:
            raise InputError(f"{label}: bufferView {i} reads a meshopt fallback buffer, "
                             "which holds no data")
        else:
            view["buffer"] = renumber[view["buffer"]]
        new_views.append(view)
    out["bufferViews"] = new_views
    out["accessors"] = [dict(a) if isinstance(a, dict) else a
                        for a in header.get("accessors") or []]
    _dequantize_positions(out, bin_, label)
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
    body = b"".join([_CHUNK.pack(len(text), b"JSON"), text,
                     _CHUNK.pack(len(bin_), _BIN), bytes(bin_)])
    return _HEADER.pack(b"glTF", 2, _HEADER.size + len(body)) + body, out
