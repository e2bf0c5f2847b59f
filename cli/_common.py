"""Output helpers shared by the subcommands: JSON or text, atomic files, errors, estimates.

Output paths are checked before any work (:func:`check_output_file`,
:func:`check_output_folder`: a probe that files can be made there). A long
run says how long first, on stderr (:func:`warn_estimate`,
:class:`RateEstimate`).
"""

from __future__ import annotations

import json
import logging
import os
import sys
import time
from pathlib import Path

from viscore import InputError, cpu_cores
from viscore._atomic import check_output_path, file_mode, write_atomic
from viscore._jobs import JOBS_PER_CORE
from viscore._validate import as_positive_int
from viscore.exchange import SAVE_FORMATS, mesh_bytes, mesh_format, save_mesh
from viscore.metrics import jsonable

__all__ = ["dumps", "emit", "check_output_path", "write_atomic", "file_mode", "check_mesh_path",
           "check_occluder_path", "write_mesh", "write_occluder", "occluder_bytes", "parse_list",
           "check_output_folder", "check_output_file", "format_duration", "warn_estimate",
           "ESTIMATE_WARN_SECONDS", "RateEstimate", "MESH_FORMATS", "OCCLUDER_FORMATS"]

_log = logging.getLogger("viscore.cli")

#: A run estimated to take longer than this, seconds, says so on stderr first
#: (:func:`warn_estimate`): a few minutes, past which a user who meant a short
#: run wants to know before waiting.
ESTIMATE_WARN_SECONDS = 180.0


def dumps(document: dict) -> str:
    """JSON text of a result document; NaN and inf become null."""
    return json.dumps(jsonable(document), indent=2)


def emit(document: dict, as_json: bool, text: str) -> None:
    """Print the JSON document or the human-readable text on stdout.

    A text stdout cannot encode (a file name's undecodable bytes, as Python holds
    them, under a locale whose stdout is strict UTF-8) is printed with those
    characters as backslash escapes, after the files were written, rather than
    an internal error.
    """
    out = dumps(document) if as_json else text
    try:
        print(out)
    except UnicodeEncodeError:  # raised before anything is written
        encoding = getattr(sys.stdout, "encoding", None) or "utf-8"
        print(out.encode(encoding, "backslashreplace").decode(encoding))


def check_utf8_name(text: str, what: str) -> str:
    """Refuse a name that is not valid UTF-8 (a file name's undecodable bytes, which
    Python holds as surrogates): where it names rows of a database or a study's files,
    it cannot be stored.

    Raises
    ------
    InputError
        One line naming ``what``, with the name's bytes escaped.
    """
    from viscore import InputError

    try:
        str(text).encode("utf-8")
    except UnicodeEncodeError:
        shown = os.fsencode(text) if isinstance(text, str) else text
        raise InputError(f"{what} {shown!r}: the name is not UTF-8 (its rows and files are "
                         "named by it as text); rename the file") from None
    return text


#: Mesh formats the CLI writes (:data:`viscore.exchange.mesh_io.SAVE_FORMATS`).
MESH_FORMATS = SAVE_FORMATS


def check_mesh_path(path: str | os.PathLike) -> str:
    """The format of an output mesh path, checked before any work.

    Raises
    ------
    InputError
        For an unknown suffix (:func:`viscore.exchange.mesh_io.mesh_format`), or a path
        :func:`check_output_path` refuses (missing folder, a directory).
    """
    suffix = mesh_format(path)
    check_output_path(path)
    return suffix


#: Formats an occluder is written in beside :data:`MESH_FORMATS`: Godot 4 text files
#: (:func:`write_occluder`).
OCCLUDER_FORMATS = frozenset({"tres", "tscn"})


def check_occluder_path(path: str | os.PathLike) -> str:
    """The format of an output occluder path, checked before any work.

    One of :data:`MESH_FORMATS` or :data:`OCCLUDER_FORMATS` (``.tres``,
    ``.tscn``), and a path :func:`check_output_path` accepts.

    Raises
    ------
    InputError
        For an unknown suffix (one line listing the formats), a missing
        folder, a directory.
    """
    from viscore import InputError

    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in MESH_FORMATS | OCCLUDER_FORMATS:
        raise InputError(f"{path}: unknown occluder format '.{suffix}'; use "
                         + ", ".join(f".{f}" for f in sorted(MESH_FORMATS | OCCLUDER_FORMATS)))
    check_output_path(path)
    return suffix


def check_output_file(path: str | os.PathLike, option: str, *, mesh: bool = False,
                      occluder: bool = False) -> Path:
    """An output file of ``option``, refused before any work unless it can be written.

    As :func:`check_output_path` (its folder must exist, it must not be a
    folder), for a mesh its format (:func:`check_mesh_path`) and for an
    occluder its format (:func:`check_occluder_path`: a mesh format or
    ``.tres``/``.tscn``); then files
    must be creatable in its folder, probed by making and removing a
    temporary folder there (as :func:`check_output_folder`: permission bits
    say nothing for root, nor for a read-only mount). Files written beside it
    (a hierarchy's ``STEM.hierarchy.json`` and node meshes) share its folder
    and so the probe.

    Raises
    ------
    InputError
        One line naming ``option``, the path and the problem.
    """
    from viscore import InputError

    try:
        if occluder:
            check_occluder_path(path)
        elif mesh:
            check_mesh_path(path)
        else:
            check_output_path(path)
    except InputError as exc:
        raise InputError(f"{option} {exc}") from None
    path = Path(path)
    problem = _cannot_write_in(path.absolute().parent)
    if problem:
        raise InputError(f"{option} {path}: cannot write in {str(path.parent)!r} ({problem})")
    return path


def _cannot_write_in(folder: Path) -> str | None:
    """Why files cannot be made in ``folder`` (an existing folder), or None when they can."""
    import tempfile

    try:
        os.rmdir(tempfile.mkdtemp(prefix=".viscore-", dir=folder))
    except OSError as exc:
        return str(exc.strerror or exc)
    return None


def write_mesh(path: str | os.PathLike, mesh) -> None:
    """Export a mesh atomically in the format its suffix names (:func:`viscore.exchange.save_mesh`).

    OBJ, OFF and PLY keep float64 coordinates; STL and GLB (float32 by their
    specifications) refuse a mesh float32 cannot hold, with one line.
    """
    save_mesh(mesh, path, format=check_mesh_path(path))


def write_occluder(path: str | os.PathLike, mesh, *, name: str) -> None:
    """Write one occluder atomically, in the format its suffix names (:func:`occluder_bytes`)."""
    write_atomic(path, occluder_bytes(path, mesh, name=name))


def occluder_bytes(path: str | os.PathLike, mesh, *, name: str) -> bytes:
    """The content of one occluder file, in the format the suffix of ``path`` names.

    - ``.tres``: one Godot 4 ``ArrayOccluder3D`` resource
      (:func:`viscore.tres_text`);
    - ``.tscn``: a Godot 4 scene holding one ``OccluderInstance3D`` node
      ``name`` with that occluder, untransformed (:func:`viscore.tscn_text`);
    - ``.glb``: the GLB :func:`write_mesh` writes, but for its one node, named
      ``<name>-occonly`` (Godot imports it as an occluder that is not drawn);
      same accessors, buffers and mesh;
    - any other mesh format: what :func:`write_mesh` writes
      (:func:`viscore.exchange.mesh_io.mesh_bytes`).

    Godot and GLB store float32: a mesh float32 cannot hold is refused with
    one line, as :func:`viscore.exchange.mesh_io.mesh_bytes` refuses it for GLB;
    otherwise the file reads back (:func:`viscore.load_occluder`) as the
    mesh's float32 triangles.

    Raises
    ------
    InputError
        An unknown suffix, a mesh float32 cannot hold, input the Godot
        writers refuse (one line naming the path).
    """
    import trimesh

    from viscore import InputError, OccluderInstance, tres_text, tscn_text
    from viscore.exchange import with_buffer_view_targets

    fmt = check_occluder_path(path)
    if fmt not in ("tres", "tscn", "glb"):
        return mesh_bytes(mesh, fmt, name=path)
    mesh_bytes(mesh, "glb", name=path)  # float32 must hold it: refused as for GLB
    vertices, indices = mesh.vertices, mesh.faces.reshape(-1)
    try:
        if fmt == "tres":
            data = tres_text(vertices, indices).encode("utf-8")
        elif fmt == "tscn":
            data = tscn_text([OccluderInstance(name, "occluder")],
                             {"occluder": (vertices, indices)}).encode("utf-8")
        else:  # the same GLB but for its node's name (trimesh names geometries alike)
            scene = trimesh.Scene()
            scene.add_geometry(mesh, node_name=f"{name}-occonly")
            data = with_buffer_view_targets(trimesh.exchange.gltf.export_glb(scene))
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    return data


def parse_list(text: str, kind: type, option: str) -> tuple:
    """Comma-separated positive numbers of an option, or InputError naming it."""
    from viscore import InputError

    try:
        values = tuple(kind(v) for v in str(text).split(",") if v.strip())
    except ValueError as exc:
        raise InputError(f"{option}: expected comma-separated numbers, got {text!r}") from exc
    if not values or min(values) <= 0:
        raise InputError(f"{option}: expected positive numbers, got {text!r}")
    return values


def check_output_folder(path: str | os.PathLike, option: str = "--out") -> Path:
    """An output folder, refused before any work unless files can be made in it.

    The folder may exist; if not, its parent must (only the last component is
    created, by the caller, at the end). Writability is probed by making and
    removing a temporary folder where the files will go: permission bits say
    nothing for root, nor for a read-only mount such as ``/proc``.

    Raises
    ------
    InputError
        One line naming the path and the problem.
    """
    from viscore import InputError

    path = Path(path)
    if os.path.lexists(path):
        if not path.is_dir():
            raise InputError(f"{option} {path}: exists and is not a folder")
        where = path
    else:
        where = path.absolute().parent
        if not where.is_dir():
            raise InputError(f"{option} {path}: the folder {str(path.parent)!r} does not "
                             "exist (it is not created)")
    problem = _cannot_write_in(where)
    if problem:
        raise InputError(f"{option} {path}: cannot write in {str(where)!r} ({problem})")
    return path


def format_duration(seconds: float) -> str:
    """A duration for a human: ``45 s``, ``12 min``, ``3.5 h``, ``36 days``, ``2.1e+03 years``.

    Examples
    --------
    >>> format_duration(45), format_duration(720), format_duration(12600)
    ('45 s', '12 min', '3.5 h')
    """
    if not seconds < float("inf"):
        return "forever"
    for unit, size in (("years", 365.25 * 86400), ("days", 86400.0), ("h", 3600.0),
                       ("min", 60.0)):
        if seconds >= 2 * size if unit in ("years", "days") else seconds >= size:
            value = seconds / size
            return f"{value:.2g} {unit}" if value < 10 or value >= 1000 else f"{value:.0f} {unit}"
    return f"{seconds:.0f} s"


def warn_estimate(what: str, seconds: float, basis: str) -> bool:
    """Say on stderr (a log line) that ``what`` will take ``seconds``, when that is long.

    Only beyond :data:`ESTIMATE_WARN_SECONDS`; stdout (``--json``) is never
    touched, and ``--quiet`` silences it with the other log lines. Returns
    whether it was said.
    """
    if seconds <= ESTIMATE_WARN_SECONDS:
        return False
    from viscore.generators import UNHELD

    _log.warning("%s: estimated %s (%s); Ctrl-C stops it", what, format_duration(seconds),
                 basis, extra={UNHELD: True})  # said now, when a command holds its records
    return True


class RateEstimate:
    """A progress callback that times a small first batch and warns of a long run once.

    Wraps ``update`` (a progress bar's, or None) for ``total`` steps of
    ``what``. The first step is not timed: it carries the run's warm-up
    (imports, numba's compilation, the scenes and pools made on first use),
    which a short run's rate must not spread over every step to come. From
    its end, once :data:`FIRST_SECONDS` have passed or :data:`FIRST_SHARE` of
    the steps are done, the remaining time is estimated from the rate of the
    steps since, and said with :func:`warn_estimate` when long.
    ``clock`` (seconds, :func:`time.perf_counter` by default) is for tests.

    Examples
    --------
    A first step of 60 s (compiling), then 2 s a step: the 100 steps to go
    take 200 s (said once the two steps after the first took 4 s).

    >>> now = [0.0]
    >>> tick = RateEstimate("x", 103, "steps", clock=lambda: now[0])
    >>> for seconds in (60.0, 2.0, 2.0):
    ...     now[0] += seconds
    ...     tick()
    >>> tick.estimate
    200.0
    """

    #: Seconds of work that make a first batch, at most.
    FIRST_SECONDS = 3.0
    #: Share of the steps that make a first batch, at most.
    FIRST_SHARE = 0.05

    def __init__(self, what: str, total: int, unit: str, update=None, *,
                 clock=time.perf_counter) -> None:
        self.what, self.total, self.unit, self._update = what, int(total), unit, update
        self.done = 0
        self._clock = clock
        self._warm: tuple[float, int] | None = None  # (time, steps) at the first step's end
        self._said = False
        #: The remaining seconds estimated once (None before).
        self.estimate: float | None = None

    def __call__(self, n: int = 1) -> None:
        self.done += n
        if self._update is not None:
            self._update(n)
        if self._said or self.done <= 0 or self.done >= self.total:
            return
        now = self._clock()
        if self._warm is None:
            self._warm = (now, self.done)
            return
        elapsed, steps = now - self._warm[0], self.done - self._warm[1]
        if elapsed < self.FIRST_SECONDS and self.done < self.FIRST_SHARE * self.total:
            return
        self._said = True
        per = elapsed / steps
        self.estimate = per * (self.total - self.done)
        warn_estimate(self.what, self.estimate,
                      f"{self.total - self.done:,} {self.unit} to go at {per:.3g} s each, "
                      f"measured on {steps:,} after the first")


def check_jobs(value: object, scheduler: object = None) -> int:
    """``--jobs`` of compare, occlude and cull: a positive integer, at most
    :data:`viscore._jobs.JOBS_PER_CORE` per core unless a ``--scheduler`` runs the jobs."""
    jobs = as_positive_int(value, "--jobs")
    if scheduler is None:
        cores = cpu_cores()
        if jobs > JOBS_PER_CORE * cores:
            raise InputError(f"--jobs {jobs}: at most {JOBS_PER_CORE * cores} "
                             f"({JOBS_PER_CORE} per core, {cores} cores)")
    return jobs
