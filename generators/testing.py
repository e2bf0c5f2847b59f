"""The generator contract, checked: for a method author's own test suite.

References
----------
.. [1] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (ray-wise conservativeness of an occluder)
"""

from __future__ import annotations

import inspect
import math
import time
from collections.abc import Callable, Iterable

import numpy as np
import trimesh

from viscore import InputError, validate_mesh
from viscore.metrics import check_conservative

from .occluder import Occluder
from .plugins import PluginError, _plugin_output
from .registry import get_generator, parse_method
from .specs import GeneratorOption, GeneratorSpec

__all__ = ["check_generator", "CHECK_SCENES"]

#: The built-in scenes, in the order they are run; True where the input is a
#: closed solid, on which an occluder must have triangles.
CHECK_SCENES = {
    "sphere": True,        # closed icosphere, 320 triangles (more than the default budget)
    "open-sphere": False,  # the same without its top cap
    "quad": False,         # a flat square of two triangles
    "triangle": False,     # one triangle
    "huge-box": True,      # a closed box of side 1e6, off the origin
    "tiny-box": True,      # a closed box of side 1e-6
}

#: Triangle budget given to every run (raised to the method's ``min_budget``).
BUDGET = 64

#: Rays of the conservativeness check of a claimed guarantee, per scene.
CONSERVATIVE_RAYS = 20_000

#: Sides of the huge and tiny boxes, world units, and the huge one's offset.
_HUGE, _HUGE_OFFSET, _TINY = 1e6, 3e6, 1e-6


def _scene(name: str) -> trimesh.Trimesh:
    """One built-in scene, made afresh (a method may not keep what it was given)."""
    if name in ("sphere", "open-sphere"):
        mesh = trimesh.creation.icosphere(subdivisions=2)
        if name == "open-sphere":
            keep = mesh.triangles_center[:, 2] < 0.5
            mesh = trimesh.Trimesh(mesh.vertices, mesh.faces[keep], process=False)
            mesh.remove_unreferenced_vertices()
        return mesh
    if name == "quad":
        return trimesh.Trimesh([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]],  # type: ignore[arg-type]
                               [[0, 1, 2], [0, 2, 3]], process=False)
    if name == "triangle":
        return trimesh.Trimesh([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], process=False)  # type: ignore[arg-type]
    box = trimesh.creation.box()
    if name == "huge-box":
        box.apply_scale(_HUGE)
        box.apply_translation([_HUGE_OFFSET, 0.0, 0.0])
    else:
        box.apply_scale(_TINY)
    return box


def _resolve(method) -> tuple[GeneratorSpec, dict, str]:
    """``(spec, fixed options, label)`` of a name, variant, spec or plain function."""
    if isinstance(method, str):
        if ":" in method:
            variant = parse_method(method)
            return variant.spec, dict(variant.options), variant.label
        return get_generator(method), {}, method
    if isinstance(method, GeneratorSpec):
        return method, {}, method.name
    if callable(method):
        try:
            spec = GeneratorSpec.from_function(method)
        except TypeError as exc:
            raise AssertionError(f"check_generator: rule 'options' broken: {exc}") from None
        return spec, {}, spec.name
    raise InputError(f"method: expected a registered name, a GeneratorSpec or a function, "
                     f"got {type(method).__name__}")


def _fail(label: str, rule: str, detail: str, scene: str | None = None) -> AssertionError:
    where = f" on scene {scene!r}" if scene else ""
    return AssertionError(f"check_generator({label}): rule {rule!r} broken{where}: {detail}")


def _bad_values(option: GeneratorOption) -> list:
    """Values just out of an option's declared range or choices (none for a plain type)."""
    if option.choices:
        return ["not-" + "-".join(option.choices)]
    if option.type is int:
        below = (math.floor(option.low) if option.low_open else math.ceil(option.low) - 1
                 ) if option.low is not None else None
        above = (math.ceil(option.high) if option.high_open else math.floor(option.high) + 1
                 ) if option.high is not None else None
    elif option.type is float:
        below = (option.low if option.low_open else option.low - max(1.0, abs(option.low))
                 ) if option.low is not None else None
        above = (option.high if option.high_open else option.high + max(1.0, abs(option.high))
                 ) if option.high is not None else None
    else:
        return []
    return [option.type(v) for v in (below, above) if v is not None]


def _check_options(spec: GeneratorSpec, label: str) -> None:
    try:
        params = inspect.signature(spec.function).parameters
    except (TypeError, ValueError):
        params = None
    takes_any = params is None or any(p.kind is inspect.Parameter.VAR_KEYWORD
                                      for p in params.values())
    for option in spec.options:
        if not takes_any and option.name not in params:  # type: ignore[operator]
            raise _fail(label, "options", f"option {option.name!r} is declared but the "
                        "function takes no such keyword")
        if option.default is not None:
            try:
                option.check(option.default)
            except InputError as exc:
                raise _fail(label, "options", f"the default of {option.name!r} is refused by "
                            f"its own declaration ({exc})") from None
        for value in _bad_values(option):
            try:
                spec.check_params({option.name: value})
            except InputError:
                continue
            except Exception as exc:  # noqa: BLE001 - the rule is: InputError, nothing else
                raise _fail(label, "options", f"{option.name}={value!r} raised "
                            f"{type(exc).__name__}, not InputError: {exc}") from None
            raise _fail(label, "options", f"{option.name}={value!r} is outside "
                        f"{option.expected()} but was accepted")


def _run(spec: GeneratorSpec, label: str, mesh: trimesh.Trimesh, params: dict,
         scene: str, usable: bool) -> Occluder | None:
    """One run as :func:`~viscore.generators.generate` makes it, without its budget flag."""
    start = time.perf_counter()
    try:
        result = spec.function(mesh.copy(), **params)
    except InputError as exc:
        if usable:
            raise _fail(label, "non-empty output", f"refused a closed solid: {exc}",
                        scene) from None
        return None  # a clean refusal of a scene without volume
    except Exception as exc:  # noqa: BLE001 - reported as the rule it breaks
        raise _fail(label, "runs", f"raised {type(exc).__name__}: {exc}", scene) from None
    try:
        return _plugin_output(spec, result, params, time.perf_counter() - start)
    except PluginError as exc:
        raise _fail(label, "finite output", str(exc), scene) from None


def check_generator(method: str | GeneratorSpec | Callable, *,
                    scenes: Iterable[str | trimesh.Trimesh] | None = None, seed: int = 0,
                    budget: int | None = None, rays: int = CONSERVATIVE_RAYS) -> dict:
    """Check one generator against the contract; AssertionError names the first broken rule.

    Parameters
    ----------
    method : str, GeneratorSpec or callable
        A registered name or variant (``planar-sections:chain=greedy``), a
        spec, or a plain function ``f(mesh, *, budget, seed, **options)``
        (:meth:`GeneratorSpec.from_function`).
    scenes : iterable of str or trimesh.Trimesh, optional
        Names from :data:`CHECK_SCENES` (default: all of them, a few seconds
        for a cheap method), or meshes of your own (named ``mesh0``, ...;
        closed ones must get triangles).
    seed : int, optional
        Seed of the method and of the conservativeness rays. Default 0.
    budget : int, optional
        Triangle budget of every run; default 64, at least the method's
        ``min_budget``.
    rays : int, optional
        Rays of the conservativeness check where a guarantee is claimed, in
        each of its two domains (orbit, then volume). Default 20,000: a
        test's worth, so a claim that fails on under about 1 ray in 7,000
        can pass; the message gives the bound.

    Returns
    -------
    dict
        Per scene: ``triangles`` (None when refused), ``over_budget``,
        ``conservative_guaranteed`` and, where claimed,
        ``violation_upper_bound`` (one-sided 95%, the larger of the two
        domains').

    Raises
    ------
    AssertionError
        ``check_generator(NAME): rule 'RULE' broken on scene 'SCENE': ...``,
        for the first broken rule (see the module docstring).
    InputError
        An unknown method name, an unknown scene, or a bad ``seed``,
        ``budget`` or ``rays``.

    Notes
    -----
    Every mesh is first passed through :func:`viscore.validate_mesh`, as
    :func:`~viscore.generators.generate` does for a plugin. The budget rule
    is checked on the method's own output: ``generate`` would flag an
    over-budget result itself, the contract asks the method to say so.
    Methods that take no budget (``budgeted=False``) are exempt.
    Determinism is checked on the first scene.

    Examples
    --------
    >>> report = check_generator("bbox", scenes=["quad"])
    >>> report["quad"]["triangles"]
    12
    """
    from viscore._validate import as_positive_int, as_seed

    seed = as_seed(seed)
    rays = as_positive_int(rays, "rays")
    spec, fixed, label = _resolve(method)
    budget = max(spec.min_budget, BUDGET) if budget is None else as_positive_int(budget,
                                                                                 "budget")
    chosen = list(CHECK_SCENES) if scenes is None else list(scenes)
    if not chosen:
        raise InputError("scenes: expected at least one scene")
    named = []
    for i, item in enumerate(chosen):
        if isinstance(item, trimesh.Trimesh):
            named.append((f"mesh{i}", item, bool(item.is_watertight)))
        elif item in CHECK_SCENES:
            named.append((item, _scene(item), CHECK_SCENES[item]))
        else:
            raise InputError(f"scenes: unknown scene {item!r} "
                             f"(built in: {', '.join(CHECK_SCENES)})")
    _check_options(spec, label)
    try:
        params = spec.check_params({**fixed, "budget": budget, "seed": seed})
    except InputError as exc:
        raise _fail(label, "options", f"the budget and seed are refused: {exc}") from None
    report = {}
    for k, (scene, mesh, usable) in enumerate(named):
        mesh = validate_mesh(mesh, name=scene)
        occ = _run(spec, label, mesh, params, scene, usable)
        if occ is None:
            report[scene] = {"triangles": None, "over_budget": None,
                             "conservative_guaranteed": None}
            continue
        if usable and occ.triangles == 0:
            raise _fail(label, "non-empty output", "no triangles for a closed solid", scene)
        over = occ.info.get("over_budget")
        if spec.budgeted and occ.triangles > budget and over is not True:
            raise _fail(label, "budget", f"{occ.triangles} triangles for a budget of {budget}, "
                        "and info['over_budget'] is not True", scene)
        if k == 0:
            again = _run(spec, label, mesh, params, scene, usable)
            same = again is not None and (
                np.array_equal(np.asarray(occ.mesh.vertices), np.asarray(again.mesh.vertices))
                and np.array_equal(np.asarray(occ.mesh.faces), np.asarray(again.mesh.faces)))
            if not same:
                raise _fail(label, "determinism", f"seed {seed} gave {occ.triangles} "
                            f"triangles, then {again.triangles if again else 'a refusal'} "
                            "(or the same count, different triangles)", scene)
        claim = occ.info.get("conservative_guaranteed")
        entry = {"triangles": occ.triangles, "over_budget": bool(occ.triangles > budget),
                 "conservative_guaranteed": None if claim is None else bool(claim)}
        if claim and occ.triangles:
            bounds = []
            for domain in ("orbit", "volume"):
                found = check_conservative(mesh, occ.mesh, rays=rays, seed=seed, domain=domain)
                bounds.append(found.violation_upper_bound)
                if found.violations:
                    raise _fail(label, "conservative claim",
                                f"conservative_guaranteed is claimed but {found.violations} of "
                                f"{found.rays} {domain}-domain rays hit the occluder before the "
                                f"mesh (violation rate <= {found.violation_upper_bound:.3g} at "
                                f"{found.confidence:.0%}, one-sided)", scene)
            entry["violation_upper_bound"] = max(bounds)  # type: ignore[assignment]
        report[scene] = entry  # type: ignore[assignment]
    return report
