"""The generator registry: the one mapping from CLI names to generators and their options.

References
----------
.. [1] Garland, M., Heckbert, P. S. "Surface Simplification Using Quadric Error
   Metrics". Proceedings of SIGGRAPH '97, ACM, 1997, pp. 209-216.
   :DOI:`10.1145/258734.258849` (the ``qem`` baseline)
.. [2] Silvennoinen, A., Saransaari, H., Laine, S., Lehtinen, J. "Occluder
   Simplification Using Planar Sections". Computer Graphics Forum 33(1),
   2014, pp. 235-245. :DOI:`10.1111/cgf.12271` (decimation and the bounding
   box as the baselines of occluder simplification)
.. [3] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669` (engine and simplifier baselines)
.. [4] Naaji, K. "Automatic Occluder Generation". A Graphics Diary (blog),
   15 Nov 2019, and its ``melt`` library (box filling, as in ``aabb-skins``)
"""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
from collections.abc import Iterator, MutableMapping
from dataclasses import dataclass

from viscore import InputError
from viscore.voxel.wall_thickness import AUTO_MAX_CELLS

from ._precision_check import DEFAULT_MIN_PRECISION as CHECK_MIN_PRECISION
from .aabb_skins import generate_aabb_skins
from .aabb_skins.generator import BYTES_PER_CELL as AABB_BYTES_PER_CELL
from .aabb_skins.generator import MAX_VOXELS as AABB_MAX_VOXELS
from .aabb_skins.generator import TRIANGLES_PER_BOX
from .baselines import generate_bbox, generate_godot, generate_original, generate_qem
from .baselines.godot import OPTIONS as GODOT_OPTIONS
from .hybrid import generate_hybrid
from .hybrid.generator import EPS_A as HYBRID_EPS_A
from .hybrid.generator import EPS_P as HYBRID_EPS_P
from .hybrid.generator import EPS_R as HYBRID_EPS_R
from .hybrid.generator import MAX_VOXELS as HYBRID_MAX_VOXELS
from .hybrid.generator import MIN_PRECISION as HYBRID_MIN_PRECISION
from .hybrid.generator import PATCH_FACES as HYBRID_PATCH_FACES
from .hybrid.generator import VOXEL_FACES as HYBRID_VOXEL_FACES
from .hybrid.generator import VOXELS as HYBRID_VOXELS
from .occluder import Occluder
from .planar_hierarchy import generate_planar_hierarchy, register_node_occluder
from .planar_sections import generate_planar_sections
from .planar_sections.generator import OPTIONS as PLANAR_OPTIONS
from .planar_sections.generator import use_hierarchy
from .plugins import PLUGIN_GROUP, PluginError, _discover_plugins, _run_plugin
from .solid_frusta import generate_solid_frusta
from .solid_frusta.generator import use_box_source
from .specs import COMMON_OPTIONS, GeneratorOption, GeneratorSpec, check_only  # noqa: F401
from .surface_patches import generate_surface_patches
from .surface_patches.generator import OPTIONS as SURFACE_OPTIONS
from .surface_patches.generator import use_box_source as use_surface_box_source
from .terrain_drape import generate_terrain_drape
from .terrain_drape.generator import RESOLUTION as TERRAIN_RESOLUTION

__all__ = ["GeneratorOption", "GeneratorSpec", "REGISTRY", "get_generator", "generate",
           "COMMON_OPTIONS", "MethodVariant", "parse_method", "check_method", "PluginError",
           "PLUGIN_GROUP", "plugin_versions"]

_log = logging.getLogger(__name__)

class _Registry(MutableMapping):
    """The name -> :class:`GeneratorSpec` mapping; plugins join on first access.

    A :class:`dict` in every use (lookup, ``in``, iteration in registration
    order, ``items()``, item assignment), except that the first read finds
    the plugins (:func:`_discover_plugins`) once per process. A lock makes
    discovery happen once with threads; a plugin module that reads the
    registry while it is imported sees the toolkit's own methods.
    """

    def __init__(self, specs: dict[str, GeneratorSpec]) -> None:
        self._specs = dict(specs)
        self._state = "pending"  # "loading", then "done"
        self._lock = threading.RLock()

    def _load(self) -> None:
        if self._state == "done":
            return
        with self._lock:
            if self._state != "pending":  # done by another thread, or loading in this one
                return
            self._state = "loading"
            try:
                for spec in _discover_plugins(self._specs):
                    self._specs[spec.name] = spec
            finally:
                self._state = "done"

    def __getitem__(self, name: str) -> GeneratorSpec:
        self._load()
        return self._specs[name]

    def __setitem__(self, name: str, spec: GeneratorSpec) -> None:
        self._load()
        self._specs[name] = spec

    def __delitem__(self, name: str) -> None:
        self._load()
        del self._specs[name]

    def __iter__(self) -> Iterator[str]:
        self._load()
        return iter(list(self._specs))

    def __len__(self) -> int:
        self._load()
        return len(self._specs)

    def __contains__(self, name: object) -> bool:
        self._load()
        return name in self._specs

    def __repr__(self) -> str:
        self._load()
        return f"REGISTRY({', '.join(self._specs)})"

    def _rediscover(self) -> None:
        """Drop the plugins and find them again on the next access (for tests)."""
        with self._lock:
            self._specs = {k: v for k, v in self._specs.items() if v.plugin is None}
            self._state = "pending"


def _own(spec: GeneratorSpec) -> GeneratorSpec:
    """One of the toolkit's methods: its rules across options checked by a check-only call.

    Each of them checks every argument before it touches the mesh, so
    :meth:`GeneratorSpec.check_options` runs those checks, and nothing else,
    before any folder or work (:func:`viscore.generators.specs.check_only`).
    """
    return dataclasses.replace(spec, checker=check_only(spec.function))


#: aabb-skins' and solid-frusta's voxel size when neither --voxels nor --voxel-size is given.
_VOXEL_SIZING = GeneratorOption(
    "voxel_sizing", str, "auto",
    "without --voxels: 'auto', 64 voxels along the longest side or finer where walls are "
    "thinner (measured by rays along the inward normals; at most "
    f"{AUTO_MAX_CELLS / 1e6:g}M cells, seconds on a thin-walled building instead of under a "
    "second), or 'extent': 64 voxels always",
    choices=("auto", "extent"))
_VOXELS_BY_SIZING = "by --voxel-sizing: finer than 64 for thin walls (auto), or 64"

REGISTRY: MutableMapping[str, GeneratorSpec] = _Registry({
    spec.name: _own(spec) for spec in [
        GeneratorSpec(
            "aabb-skins", generate_aabb_skins,
            "greedy maximal axis-aligned boxes inside the voxelized mesh (occluder skins)",
            options=(
                GeneratorOption("voxels", int, None, "voxels along the longest bounding-box side",
                                low=1, nullable=True, default_text=_VOXELS_BY_SIZING),
                GeneratorOption("voxel_size", float, None,
                                "voxel side in world units; overrides --voxels",
                                low=0, low_open=True, nullable=True),
                _VOXEL_SIZING,
                GeneratorOption("max_boxes", int, 16, "stop after this many boxes", low=1,
                                nullable=True),
                GeneratorOption("fill", float, 0.9,
                                "stop once the boxes cover this share of the inner voxels",
                                low=0, low_open=True, high=1),
                GeneratorOption("min_volume", float, 0.0,
                                "stop at the first box smaller than this, world units^3",
                                low=0),
                GeneratorOption("seed_voxel", str, "max-volume",
                                "largest box over all voxels, or grow from the densest voxel",
                                choices=("max-volume", "densest")),
            ),
            conservative=True, min_budget=TRIANGLES_PER_BOX),
        GeneratorSpec(
            "planar-sections", generate_planar_sections,
            "double-sided planar sections of the voxelized solid, chosen by occlusion measure "
            "(Silvennoinen et al. 2014)",
            options=PLANAR_OPTIONS,
            min_budget=1),
        GeneratorSpec(
            "hybrid", generate_hybrid,
            "game buildings: planar/curved patches with hole filling and enforced voxel "
            "isosurface candidates, metric-guided face removal (Wu et al. 2022)",
            options=(
                GeneratorOption("voxels", int, HYBRID_VOXELS,
                                "N_v: voxel size is the bounding-box diagonal / voxels",
                                low=4, high=HYBRID_MAX_VOXELS),
                GeneratorOption("eps_a", float, HYBRID_EPS_A,
                                "curved-patch dihedral threshold, radians", low=0,
                                low_open=True, high=math.pi),
                GeneratorOption("grouping", str, "dihedral",
                                "curved patches by dihedral angle (the paper) or xatlas charts",
                                choices=("dihedral", "xatlas")),
                GeneratorOption("candidates", str, "combined",
                                "candidate set: patches and voxels, or one of them (ablation)",
                                choices=("combined", "patch", "voxel")),
                GeneratorOption("enforce", bool, True,
                                "conservative enforcement of the voxel candidates"),
                GeneratorOption("mgos", bool, True,
                                "metric-guided occluder simplification on the volume protocol"),
                GeneratorOption("patch_faces", int, HYBRID_PATCH_FACES,
                                "N_P: faces kept by the patch-area reduction", low=1),
                GeneratorOption("voxel_faces", int, HYBRID_VOXEL_FACES,
                                "target faces of the simplified isosurface", low=1),
                GeneratorOption("fill_holes", bool, True,
                                "fill planar-patch holes whose test segments all hit the input"),
                GeneratorOption("coplanar", bool, True,
                                "join planar patches by plane across loose parts (a panelled "
                                "wall is one patch, its recesses holes)"),
                GeneratorOption("bands", bool, False,
                                "cut planar patches with open holes into convex bands for "
                                "the patch reduction"),
                GeneratorOption("eps_p", float, HYBRID_EPS_P,
                                "metric-guided step: precision gain that removes a face",
                                low=0, high=1),
                GeneratorOption("eps_r", float, HYBRID_EPS_R,
                                "metric-guided step: recall loss below which a face goes",
                                low=0, high=1),
                GeneratorOption("min_precision", float, HYBRID_MIN_PRECISION,
                                "metric-guided step: precision floor on its views, faces of "
                                "most gain removed while under it", low=0, high=1,
                                nullable=True),
                GeneratorOption("mgos_spacing", float, None,
                                "view spacing of the metric-guided step, fraction of the "
                                "bounding-box diagonal", low=0, low_open=True, high=1,
                                nullable=True, default_text="0.12"),
                GeneratorOption("mgos_resolution", int, None,
                                "pixels per frustum side of those views", low=1, high=4096,
                                nullable=True, default_text="32"),
                GeneratorOption("mgos_quads", int, None, "quads per frustum of those views",
                                low=1, nullable=True, default_text="1000"),
            ),
            min_budget=1, heavy=True),
        GeneratorSpec(
            "solid-frusta", generate_solid_frusta,
            "a few convex solids inside the mesh (aabb-skins boxes, shrunk voxel-cluster "
            "hulls) for shadow-frustum culling",
            options=(
                GeneratorOption("voxels", int, None, "voxels along the longest bounding-box side",
                                low=1, high=2048, nullable=True,
                                default_text=_VOXELS_BY_SIZING),
                _VOXEL_SIZING,
                GeneratorOption("solids", int, 8, "at most this many convex solids", low=1),
                GeneratorOption("pieces", str, "voxel-hulls",
                                "candidates: aabb-skins boxes and shrunk convex hulls of "
                                "inner-voxel clusters, or the boxes alone",
                                choices=("voxel-hulls", "boxes-only")),
                GeneratorOption("shrink_steps", int, 6,
                                "bisection steps on a hull's scale until it lies inside",
                                low=1, high=30),
            ),
            conservative=True, min_budget=TRIANGLES_PER_BOX),
        GeneratorSpec(
            "surface-patches", generate_surface_patches,
            "double-sided polygons cut from the input's own coplanar regions (across loose "
            "parts), chosen by occlusion measure; conservative on any input (thin, open game "
            "geometry)",
            options=SURFACE_OPTIONS,
            conservative=True, min_budget=1),
        GeneratorSpec(
            "terrain-drape", generate_terrain_drape,
            "a few triangles just under an open height field (terrain, a floor), chosen on "
            "check views at the precision floor; or only where every line meets the sheet",
            options=(
                GeneratorOption("mode", str, "measured",
                                "keep the drape of best check recall at min-precision, or only "
                                "what every line through it shows covered (guaranteed, thin)",
                                choices=("measured", "hidden")),
                GeneratorOption("min_precision", float, CHECK_MIN_PRECISION,
                                "check-view precision floor of the measured mode", low=0,
                                high=1),
                GeneratorOption("up", str, "auto", "the up axis",
                                choices=("auto", "x", "y", "z")),
                GeneratorOption("resolution", int, TERRAIN_RESOLUTION,
                                "height samples along each side of a square footprint "
                                "(about its square over any footprint)",
                                low=8, high=1024),
                GeneratorOption("reach", int, 3,
                                "hidden mode: lattice directions (a, b) of the hidden floor, "
                                "max(|a|, |b|) <= reach (16 orientations at 3)", low=1, high=8),
            ),
            min_budget=2, inputs="height-fields"),
        GeneratorSpec("qem", generate_qem, "quadric edge-collapse decimation to the budget",
                      baseline=True),
        GeneratorSpec(
            "godot", generate_godot,
            "Godot 4's occluder bake: meshoptimizer simplify per surface, borders locked",
            options=GODOT_OPTIONS,
            baseline=True, budgeted=False),
        GeneratorSpec("bbox", generate_bbox, "the bounding box (non-conservative extreme)",
                      baseline=True, budgeted=False),
        GeneratorSpec("original", generate_original, "the mesh itself (P = R = 1 check)",
                      baseline=True, budgeted=False),
    ]
})


def get_generator(name: str) -> GeneratorSpec:
    """The registered generator called ``name`` (or the one a method variant
    ``name:option=value...`` runs), or :class:`InputError` listing them."""
    base = name.split(":", 1)[0].strip() if isinstance(name, str) else name
    try:
        return REGISTRY[base]
    except (KeyError, TypeError):
        raise InputError(f"method: unknown generator {name!r} "
                         f"(registered: {', '.join(REGISTRY)})") from None


@dataclass(frozen=True)
class MethodVariant:
    """A registered generator with some options fixed: ``name:option=value:...``.

    Attributes
    ----------
    spec : GeneratorSpec
        The generator.
    options : dict
        The fixed options, checked and converted to their declared types.
    label : str
        The canonical text (options sorted, values as the CLI spells them):
        what studies store as the method, so that equal variants share results.
    """

    spec: GeneratorSpec
    options: dict
    label: str


def _option_text(value: object) -> str:
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def parse_method(text: str, where: str = "method") -> MethodVariant:
    """A method name, or a variant with options: ``planar-sections:chain=greedy:reduce=area``.

    Parameters
    ----------
    text : str
        A registered name, optionally followed by ``:option=value`` items
        (options by their keyword or flag name, ``close`` or ``rdp-tolerance``;
        values as on the command line).
    where : str, optional
        What the error messages name (``--methods``).

    Returns
    -------
    MethodVariant

    Raises
    ------
    InputError
        Unknown generator or option, a malformed item, a repeated option, an
        option a study sets for every method (budget, seed), or a bad value.

    Examples
    --------
    >>> parse_method("planar-sections:reduce=area:chain=greedy").label
    'planar-sections:chain=greedy:reduce=area'
    >>> parse_method("aabb-skins").options
    {}
    """
    if not isinstance(text, str) or not text.strip():
        raise InputError(f"{where}: expected a method name, got {text!r}")
    head, *items = [part.strip() for part in text.strip().split(":")]
    if head not in REGISTRY:
        raise InputError(f"{where}: unknown method {head!r} (registered: {', '.join(REGISTRY)})")
    spec = REGISTRY[head]
    options: dict = {}
    for item in items:
        key, eq, value = item.partition("=")
        key = key.strip().replace("-", "_")
        if not eq or not key:
            raise InputError(f"{where}: {text!r}: expected {head}:option=value, got {item!r}")
        if key in COMMON_OPTIONS:
            raise InputError(f"{where}: {text!r}: {key} is set for every method of a study, "
                             "not per method")
        try:
            opt = spec.option(key)
        except KeyError:
            takes = ", ".join(o.name.replace("_", "-") for o in spec.options) or "no options"
            raise InputError(f"{where}: {head} has no option {key.replace('_', '-')!r} "
                             f"(takes: {takes})") from None
        if key in options:
            raise InputError(f"{where}: {text!r}: {key.replace('_', '-')} given twice")
        options[key] = opt.parse(value.strip(), f"{where}: {head}:{key.replace('_', '-')}")
    label = ":".join([head] + [f"{k.replace('_', '-')}={_option_text(options[k])}"
                               for k in sorted(options)])
    return MethodVariant(spec=spec, options=options, label=label)


def check_method(text: str, where: str = "method") -> MethodVariant:
    """:func:`parse_method`, then every check the method makes on the variant's options.

    A command that runs methods later (``compare``, ``cull``, ``occlude``)
    calls this on each one before it creates a folder or starts any work:
    besides each option's type and range it runs the generator's own rules
    across options (:meth:`GeneratorSpec.check_options`), so that
    ``planar-sections:pixel-error=1`` (no distance) fails here with the
    generator's message rather than inside a job.

    Parameters
    ----------
    text : str
        A method name or variant, as :func:`parse_method` takes.
    where : str, optional
        What the error messages name (``--methods``).

    Returns
    -------
    MethodVariant

    Raises
    ------
    InputError
        As :func:`parse_method`, or one line naming ``where``, the variant
        and the generator's refusal.

    Examples
    --------
    >>> check_method("planar-sections:close=2").label
    'planar-sections:close=2'
    >>> try:
    ...     check_method("planar-sections:close=2:conservative=true", "--methods")
    ... except InputError as exc:
    ...     print(exc)
    --methods: planar-sections:close=2:conservative=true: close: not with conservative ...
    """
    variant = parse_method(text, where)
    try:
        variant.spec.check_options(dict(variant.options))
    except InputError as exc:
        raise InputError(f"{where}: {variant.label}: {exc}") from None
    return variant


def generate(name: str, mesh, **params) -> Occluder:
    """Run the generator registered as ``name`` on ``mesh`` with checked ``params``.

    Parameters
    ----------
    name : str
        A key of :data:`REGISTRY`, or a method variant
        (``planar-sections:chain=greedy``, :func:`parse_method`).
    mesh : trimesh.Trimesh
        The input mesh.
    **params
        ``budget`` (int, optional), ``seed`` (int, optional) and the options
        the spec declares; checked against it before the generator runs.

    Returns
    -------
    Occluder
        When ``budget`` is given, ``info["over_budget"]`` says whether the
        occluder has more triangles than the budget; when it does (a method
        that ignores the budget, or could not meet it), one warning is logged.

    Raises
    ------
    InputError
        Unknown method or option, or a value out of type or range; for a
        plugin method also a mesh :func:`viscore.validate_mesh` refuses
        (checked before the plugin is called), or the plugin's own
        :class:`~viscore.InputError`, prefixed with its name and package.
    PluginError
        A plugin method raised any other exception, or returned something
        other than an :class:`Occluder` or a :class:`trimesh.Trimesh`, or a
        mesh with non-finite vertices or face indices out of range, or parts
        off the schema. One line naming the method, its package and version.

    Notes
    -----
    A plugin method (:attr:`GeneratorSpec.plugin`) gets the cleaned copy
    :func:`viscore.validate_mesh` returns, never an empty, non-finite or
    degenerate mesh, and its occluder's ``info["plugin"]`` records
    ``{"package": ..., "version": ...}``. The toolkit's own methods are
    called as they are.

    Examples
    --------
    >>> import trimesh
    >>> generate("bbox", trimesh.creation.icosphere()).triangles
    12
    >>> generate("bbox", trimesh.creation.icosphere(), budget=5).info["over_budget"]
    True
    """
    variant = parse_method(name) if isinstance(name, str) and ":" in name else None
    spec = variant.spec if variant else get_generator(name)
    if variant:
        twice = sorted(set(variant.options) & set(params))
        if twice:
            raise InputError(f"{name}: {', '.join(twice)} given in the method and again")
        params = {**variant.options, **params}
    params = spec.check_params(params)
    occ = (spec.function(mesh, **params) if spec.plugin is None
           else _run_plugin(spec, mesh, params))
    budget = params.get("budget")
    if budget is None:
        return occ
    over = occ.triangles > budget
    if over:
        why = ("it could not reach it" if spec.budgeted
               else "this method does not take a budget")
        _log.warning("%s: %d triangles exceed the budget of %d (%s)",
                     name, occ.triangles, budget, why)
    return dataclasses.replace(occ, info={**occ.info, "over_budget": bool(over)})


def plugin_versions(methods=None) -> dict[str, dict[str, str]]:
    """The distribution and version of each plugin method, for provenance.

    Parameters
    ----------
    methods : iterable of str, optional
        Method names or variants (``my-method:option=1``); default every
        registered method. Unknown names and the toolkit's own methods are
        left out.

    Returns
    -------
    dict
        ``{method: {"package": str, "version": str}}`` for the plugin
        methods only (empty when none), in the order given.

    Examples
    --------
    >>> plugin_versions(["bbox", "qem"])
    {}
    """
    names = REGISTRY if methods is None else methods
    out = {}
    for text in names:
        base = text.split(":", 1)[0].strip() if isinstance(text, str) else text
        spec = REGISTRY.get(base)
        if spec is not None and spec.plugin is not None:
            out[base] = {"package": spec.plugin[0], "version": spec.plugin[1]}
    return out


# --------------------------------------------------------------------------- composition
# The families never import each other; what one uses of another is handed over here.

def _qem_builder(mesh, *, budget, seed, **options):
    return generate_qem(mesh, budget=budget, seed=seed, **options)


def _aabb_skins_builder(mesh, *, budget, seed, voxel_size, **options):
    return generate_aabb_skins(mesh, budget=budget, seed=seed, voxel_size=voxel_size,
                               **options)


# the hierarchy's per-node builders (sec. 5: planar sections at every node)
register_node_occluder("planar-sections", generate_planar_sections)
register_node_occluder("qem", _qem_builder)
register_node_occluder("aabb-skins", _aabb_skins_builder)
# planar-sections --hierarchy: the sec. 5 hierarchy with planar sections at every node
use_hierarchy(generate_planar_hierarchy)
# solid-frusta's candidate boxes are aabb-skins' boxes
use_box_source(generate_aabb_skins, max_voxels=AABB_MAX_VOXELS,
               bytes_per_cell=AABB_BYTES_PER_CELL["max-volume"])
# surface-patches' boxes in the closed parts are aabb-skins' boxes too
use_surface_box_source(generate_aabb_skins)
