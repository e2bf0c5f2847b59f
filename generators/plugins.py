"""Generator plugins: methods of other installed packages, found by entry point."""

from __future__ import annotations

import contextlib
import dataclasses
import importlib.metadata
import logging
import os
import signal
import sys
import threading
import time

import numpy as np
import trimesh

from viscore import InputError, validate_mesh

from .occluder import Occluder, check_parts
from .specs import (  # noqa: F401,E501
    COMMON_OPTIONS,
    GeneratorOption,
    GeneratorSpec,
    _occluder_from,
    _spec_from_function,
)

_log = logging.getLogger(__name__)

# --------------------------------------------------------------------------- plugins

#: The entry-point group other distributions register methods under.
PLUGIN_GROUP = "viscore.generators"

#: Set to 1 (or true, yes) to leave the plugins out.
_NO_PLUGINS_ENV = "VISCORE_NO_PLUGINS"

#: Version recorded for a plugin whose entry point has no distribution.
_UNKNOWN = "unknown"

#: Seconds a plugin's import may take before one warning line says so and names
#: :data:`_NO_PLUGINS_ENV` (importing a plugin that pulls in a deep-learning stack
#: can take this long on a loaded machine; a hung one must not look like viscore).
IMPORT_WARN_SECONDS = 5.0
#: Seconds after which a plugin's import is stopped and the plugin left out.
IMPORT_LIMIT_SECONDS = 30.0


class PluginError(RuntimeError):
    """A plugin method failed when called or returned an unusable occluder.

    The message is one line naming the method, its distribution and version.
    Not an :class:`~viscore.InputError`: the input was valid, the plugin is
    at fault (the command line reports it as an internal error, exit 3).
    """


class _PluginProblem(Exception):
    """Why one entry point is left out (one warning line)."""


def _plugins_disabled() -> bool:
    return os.environ.get(_NO_PLUGINS_ENV, "").strip().lower() in {"1", "true", "yes"}


def _entry_points() -> list:
    """The installed entry points of :data:`PLUGIN_GROUP` (tests replace this)."""
    return list(importlib.metadata.entry_points(group=PLUGIN_GROUP))


def _distribution(ep) -> tuple[str, str]:
    dist = getattr(ep, "dist", None)
    if dist is not None:
        name = dist.metadata["Name"] if dist.metadata is not None else None
        return (name or getattr(dist, "name", None) or _UNKNOWN, dist.version or _UNKNOWN)
    return (ep.value.split(":", 1)[0].split(".", 1)[0].strip() or _UNKNOWN, _UNKNOWN)


def _discover_plugins(taken: dict[str, GeneratorSpec]) -> list[GeneratorSpec]:
    """The plugin specs to add to ``taken``; a bad entry point costs one warning line.

    Entry points are read in name order (then value), so that of two
    plugins claiming one name the same one wins on every machine.
    """
    if _plugins_disabled():
        return []
    try:
        eps = sorted(_entry_points(), key=lambda ep: (ep.name, ep.value))
    except Exception as exc:  # noqa: BLE001 - broken metadata must not stop the toolkit
        _log.warning("plugins: cannot read the %s entry points (%s: %s); none loaded",
                     PLUGIN_GROUP, type(exc).__name__, _one_line(exc))
        return []
    found: dict[str, GeneratorSpec] = {}
    # what a plugin prints while it is imported goes to stderr: stdout is the --json
    # document's alone
    with contextlib.redirect_stdout(sys.stderr):
        for ep in eps:
            dist = _distribution(ep)
            try:
                spec = _load_plugin(ep, dist, {**taken, **found})
            except _PluginProblem as exc:
                _log.warning("plugin %r (%s %s, %s): %s; left out", ep.name, *dist, ep.value,
                             _one_line(exc))
                continue
            found[spec.name] = spec
            _log.debug("plugin %r (%s %s) registered", spec.name, *dist)
    return list(found.values())


class _ImportTimeout(BaseException):
    """Raised into a plugin's import that passed :data:`IMPORT_LIMIT_SECONDS` (a
    BaseException, so that the plugin's own ``except Exception`` does not keep it)."""


@contextlib.contextmanager
def _import_bounds(ep, dist: tuple[str, str]):
    """Bound a plugin's import in time, and tell a Ctrl-C from a plugin's own exceptions.

    In the main thread (where Python runs signal handlers) an interval timer
    says once, after :data:`IMPORT_WARN_SECONDS`, that the import is still
    running and how to start without plugins, then stops it after
    :data:`IMPORT_LIMIT_SECONDS` (:class:`_ImportTimeout`). A SIGINT during the
    import is recorded in the yielded list, so that the caller re-raises a real
    Ctrl-C and leaves out a plugin that raises KeyboardInterrupt itself. Elsewhere
    (a thread, a system without ``setitimer``) the import is not bounded.
    """
    interrupted: list[bool] = []
    if threading.current_thread() is not threading.main_thread() \
            or not hasattr(signal, "setitimer"):
        yield interrupted
        return
    warned = []  # type: ignore[var-annotated]

    def on_alarm(signum, frame):
        if not warned:
            warned.append(True)
            _log.warning("plugin %r (%s %s) is still importing after %g s; waiting up to %g s "
                         "for it (set %s=1 to start without plugins)", ep.name, *dist,
                         IMPORT_WARN_SECONDS, IMPORT_LIMIT_SECONDS, _NO_PLUGINS_ENV)
            signal.setitimer(signal.ITIMER_REAL, IMPORT_LIMIT_SECONDS - IMPORT_WARN_SECONDS)
            return
        raise _ImportTimeout

    def on_sigint(signum, frame):
        interrupted.append(True)
        raise KeyboardInterrupt

    old_alarm = signal.signal(signal.SIGALRM, on_alarm)
    # only Python's own Ctrl-C handler is wrapped (an ignored SIGINT stays ignored)
    old_int = signal.getsignal(signal.SIGINT)
    if old_int is signal.default_int_handler:
        signal.signal(signal.SIGINT, on_sigint)
    signal.setitimer(signal.ITIMER_REAL, min(IMPORT_WARN_SECONDS, IMPORT_LIMIT_SECONDS))
    try:
        yield interrupted
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old_alarm)
        if old_int is signal.default_int_handler:
            signal.signal(signal.SIGINT, old_int)


def _import_plugin(ep, dist: tuple[str, str]):
    """``ep.load()``, bounded (:func:`_import_bounds`); whatever the plugin raises, a
    ``sys.exit`` or a KeyboardInterrupt of its own included, leaves it out."""
    with _import_bounds(ep, dist) as interrupted:
        try:
            return ep.load()
        except _ImportTimeout:
            raise _PluginProblem(f"its import did not finish in {IMPORT_LIMIT_SECONDS:g} s "
                                 f"(set {_NO_PLUGINS_ENV}=1 to start without plugins)") from None
        except SystemExit as exc:
            raise _PluginProblem(f"its import called sys.exit({exc.code!r})") from None
        except KeyboardInterrupt:
            if interrupted:  # a real Ctrl-C: the command stops
                raise
            raise _PluginProblem("its import raised KeyboardInterrupt") from None
        except Exception as exc:  # noqa: BLE001 - any failure of a plugin's import is its own
            raise _PluginProblem(f"cannot be loaded: {type(exc).__name__}: {exc}") from None


def _one_line(text: object) -> str:
    return " ".join(str(text).split())


def _load_plugin(ep, dist: tuple[str, str], taken: dict) -> GeneratorSpec:
    name = ep.name
    if name in taken:
        owner = taken[name].plugin
        raise _PluginProblem(f"the name {name!r} is taken by "
                             + (f"the plugin of {owner[0]} {owner[1]}" if owner
                                else "a built-in method"))
    if not name or ":" in name or "," in name or name != name.strip() or " " in name:
        raise _PluginProblem(f"{name!r} is not a method name (no spaces, ':' or ',')")
    obj = _import_plugin(ep, dist)
    if isinstance(obj, GeneratorSpec):
        if obj.name != name:
            raise _PluginProblem(f"its GeneratorSpec is named {obj.name!r}, not {name!r}")
        problems = _spec_problems(obj)
        if problems:
            raise _PluginProblem(problems)
        return dataclasses.replace(obj, plugin=dist)
    if callable(obj):
        try:
            spec = _spec_from_function(obj, name, None)
        except TypeError as exc:
            raise _PluginProblem(str(exc)) from None
        return dataclasses.replace(spec, plugin=dist)
    raise _PluginProblem(f"names a {type(obj).__name__}, not a GeneratorSpec or a function")


def _spec_problems(spec: GeneratorSpec) -> str | None:
    if not callable(spec.function):
        return "its GeneratorSpec's function is not callable"
    if not all(isinstance(o, GeneratorOption) for o in spec.options):
        return "its GeneratorSpec's options are not all GeneratorOption"
    names = [o.name for o in spec.options]
    if len(set(names)) != len(names) or set(names) & set(COMMON_OPTIONS):
        return "its GeneratorSpec declares an option twice, or budget or seed"
    if isinstance(spec.min_budget, bool) or not isinstance(spec.min_budget, int) \
            or spec.min_budget < 1:
        return f"its GeneratorSpec's min_budget must be an integer >= 1, got {spec.min_budget!r}"
    return None


def _who(spec: GeneratorSpec) -> str:
    package, version = spec.plugin or ("viscore", "built-in")
    return f"plugin method {spec.name!r} ({package} {version})"


def _run_plugin(spec: GeneratorSpec, mesh, params: dict) -> Occluder:
    """Call a plugin on a validated mesh and check what it returns."""
    mesh = validate_mesh(mesh)
    start = time.perf_counter()
    try:
        result = spec.function(mesh, **params)
    except InputError as exc:
        raise InputError(f"{_who(spec)}: {exc}") from exc
    except Exception as exc:  # noqa: BLE001 - reported, with the plugin named
        raise PluginError(f"{_who(spec)} raised {type(exc).__name__}: "
                          f"{_one_line(exc)}") from exc
    occ = _plugin_output(spec, result, params, time.perf_counter() - start)
    package, version = spec.plugin or ("viscore", "built-in")
    return dataclasses.replace(occ, info={**occ.info,
                                          "plugin": {"package": package, "version": version}})




def _plugin_output(spec: GeneratorSpec, result, params: dict, seconds: float) -> Occluder:
    """The occluder a method returned, checked: finite vertices, faces indexing them, parts.

    Raises :class:`PluginError` naming the method and the first problem.
    """
    occ = _occluder_from(result, spec.name, params, seconds)
    if not isinstance(occ, Occluder):
        raise PluginError(f"{_who(spec)} returned a {type(result).__name__}, expected an "
                          "Occluder or a trimesh.Trimesh")
    if not isinstance(occ.mesh, trimesh.Trimesh):
        raise PluginError(f"{_who(spec)} returned an Occluder whose mesh is a "
                          f"{type(occ.mesh).__name__}, not a trimesh.Trimesh")
    vertices = np.asarray(occ.mesh.vertices)
    faces = np.asarray(occ.mesh.faces)
    if vertices.ndim != 2 or vertices.shape[1] != 3 or not np.issubdtype(vertices.dtype,
                                                                         np.number):
        raise PluginError(f"{_who(spec)} returned vertices of shape {vertices.shape}, "
                          "expected (n, 3) numbers")
    bad = int(np.count_nonzero(~np.isfinite(vertices).all(axis=1)))
    if bad:
        raise PluginError(f"{_who(spec)} returned {bad} of {len(vertices)} vertices "
                          "not finite (NaN or infinite)")
    if faces.ndim != 2 or faces.shape[1] != 3 or (len(faces)
                                                  and not np.issubdtype(faces.dtype, np.integer)):
        raise PluginError(f"{_who(spec)} returned faces of shape {faces.shape} "
                          f"({faces.dtype}), expected (m, 3) integers")
    if len(faces) and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise PluginError(f"{_who(spec)} returned faces indexing vertices outside "
                          f"0..{len(vertices) - 1} (min {int(faces.min())}, "
                          f"max {int(faces.max())})")
    if not isinstance(occ.info, dict) or not isinstance(occ.parts, dict):
        raise PluginError(f"{_who(spec)} returned an Occluder whose info or parts "
                          "is not a dict")
    try:
        check_parts(occ.parts)
    except ValueError as exc:
        raise PluginError(f"{_who(spec)} returned parts off the schema: {exc}") from None
    return occ


# plain-function plugins ------------------------------------------------------------

