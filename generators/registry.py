"""The generator registry: the one mapping from CLI names to generators and their options.

Each generator is ``function(mesh, *, budget=..., seed=..., **options) -> Occluder``.
Its :class:`GeneratorSpec` declares the options beyond ``budget`` and ``seed``
(:class:`GeneratorOption`: name, type, default, range, choices, help); the
command line builds ``viscore generate METHOD`` and its flags from them, and
:func:`generate` checks every value against them before any work. A new method
is one module plus one entry in :data:`REGISTRY`: it then appears in
``viscore generate --help`` and joins every study, with no change under ``cli/``.

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
import numbers
from collections.abc import Callable
from dataclasses import dataclass

from viscore import InputError
from viscore._validate import as_positive_int, as_seed

from .aabb_skins import generate_aabb_skins
from .aabb_skins.generator import BYTES_PER_CELL as AABB_BYTES_PER_CELL
from .aabb_skins.generator import MAX_VOXELS as AABB_MAX_VOXELS
from .aabb_skins.generator import TRIANGLES_PER_BOX
from .baselines import generate_bbox, generate_godot, generate_original, generate_qem
from .hybrid import generate_hybrid
from .hybrid.generator import EPS_A as HYBRID_EPS_A
from .hybrid.generator import EPS_P as HYBRID_EPS_P
from .hybrid.generator import EPS_R as HYBRID_EPS_R
from .hybrid.generator import MAX_VOXELS as HYBRID_MAX_VOXELS
from .hybrid.generator import PATCH_FACES as HYBRID_PATCH_FACES
from .hybrid.generator import VOXEL_FACES as HYBRID_VOXEL_FACES
from .hybrid.generator import VOXELS as HYBRID_VOXELS
from .occluder import Occluder
from .planar_hierarchy import generate_planar_hierarchy, register_node_occluder
from .planar_sections import generate_planar_sections
from .planar_sections.generator import DEFAULT_ALPHA as PLANAR_ALPHA
from .planar_sections.generator import DEFAULT_DEPTH_BINS as PLANAR_DEPTH_BINS
from .planar_sections.generator import DEFAULT_DIRECTION_BINS as PLANAR_DIRECTION_BINS
from .planar_sections.generator import DEFAULT_FOV as PLANAR_FOV
from .planar_sections.generator import DEFAULT_SCREEN as PLANAR_SCREEN
from .planar_sections.generator import MAX_VOXELS as PLANAR_MAX_VOXELS
from .planar_sections.generator import RDP_TOLERANCE as PLANAR_RDP_TOLERANCE
from .planar_sections.generator import use_hierarchy
from .solid_frusta import generate_solid_frusta
from .solid_frusta.generator import use_box_source

__all__ = ["GeneratorOption", "GeneratorSpec", "REGISTRY", "get_generator", "generate",
           "COMMON_OPTIONS", "MethodVariant", "parse_method"]

_log = logging.getLogger(__name__)

#: Option types a spec may declare.
_TYPES = {int: "an integer", float: "a number", str: "a string", bool: "true or false"}


#: Words :meth:`GeneratorOption.parse` reads as a ``bool``.
_BOOL_WORDS = {"true": True, "yes": True, "1": True, "false": False, "no": False, "0": False}


def _flag(name: str) -> str:
    """The command-line flag of an option name: ``max_boxes`` -> ``--max-boxes``."""
    return "--" + name.replace("_", "-")


@dataclass(frozen=True)
class GeneratorOption:
    """One keyword option of a generator, as the registry declares it.

    Attributes
    ----------
    name : str
        The generator's keyword (``max_boxes``); the CLI flag is the same
        with dashes (``--max-boxes``).
    type : {int, float, str, bool}
        Value type. Integers are not accepted for ``str``; integers are
        accepted for ``float``; floats are refused for ``int``; only
        ``True`` and ``False`` are a ``bool`` (on the CLI a switch pair,
        ``--conservative`` / ``--no-conservative``).
    default : object
        The generator's own default (a test checks the two agree); ``None``
        when the default is computed from the mesh (``help`` says how).
    help : str
        One line for ``--help``, with the unit of lengths.
    low, high : float, optional
        Range of numbers, inclusive unless ``low_open`` / ``high_open``.
        Floats are also required to be finite.
    low_open, high_open : bool, optional
        Exclude the bound itself (``(0, 1]`` is ``low=0, low_open=True, high=1``).
    choices : tuple of str, optional
        The values a ``str`` option takes.
    nullable : bool, optional
        ``None`` is a valid value (on the CLI: ``none``), e.g. no box limit.
    default_text : str, optional
        How ``--help`` states a default computed from the mesh.
    """

    name: str
    type: type
    default: object
    help: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: tuple[str, ...] | None = None
    nullable: bool = False
    default_text: str | None = None

    def __post_init__(self) -> None:
        if self.type not in _TYPES:
            raise TypeError(f"option {self.name}: type must be int, float, str or bool")

    @property
    def flag(self) -> str:
        """The command-line flag, ``--`` and the name with dashes."""
        return _flag(self.name)

    def expected(self) -> str:
        """What a valid value is, in words: ``an integer >= 1``, ``one of a, b``."""
        if self.choices:
            text = "one of " + ", ".join(self.choices)
        else:
            text = _TYPES[self.type]
            bounds = []
            if self.low is not None:
                bounds.append(f"{'>' if self.low_open else '>='} {self.low:g}")
            if self.high is not None:
                bounds.append(f"{'<' if self.high_open else '<='} {self.high:g}")
            if bounds:
                text += " " + " and ".join(bounds)
        return text + (", or none" if self.nullable else "")

    def check(self, value: object, label: str | None = None) -> object:
        """``value`` converted to the option's type, or :class:`InputError` naming ``label``."""
        label = label or self.name
        if value is None and self.nullable:
            return None
        bad = InputError(f"{label}: expected {self.expected()}, got {value!r}")
        if self.type is bool:
            if not isinstance(value, bool):
                raise bad
            return value
        if self.type is str:
            if not isinstance(value, str) or (self.choices and value not in self.choices):
                raise bad
            return value
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise bad
        if self.type is int:
            if not isinstance(value, numbers.Integral):
                raise bad
            value = int(value)
        else:
            value = float(value)
            if not math.isfinite(value):
                raise bad
        if self.low is not None and (value < self.low or (self.low_open and value == self.low)):
            raise bad
        if self.high is not None and (value > self.high
                                      or (self.high_open and value == self.high)):
            raise bad
        return value

    def parse(self, text: str, label: str | None = None) -> object:
        """A command-line string converted and checked, or :class:`InputError`."""
        label = label or self.flag
        if self.nullable and text.strip().lower() == "none":
            return None
        if self.type is str:
            return self.check(text, label)
        if self.type is bool:
            word = text.strip().lower()
            if word not in _BOOL_WORDS:
                raise InputError(f"{label}: expected {self.expected()}, got {text!r}")
            return _BOOL_WORDS[word]
        try:
            value = int(text) if self.type is int else float(text)
        except ValueError:
            raise InputError(f"{label}: expected {self.expected()}, got {text!r}") from None
        return self.check(value, label)

    def describe(self) -> str:
        """The ``--help`` line: help, accepted values and default."""
        default = self.default_text or ("none" if self.default is None else self.default)
        return f"{self.help} ({self.expected()}; default: {default})"


#: Options every generator takes, handled by :func:`generate` itself: ``budget``
#: (a generator that ignores it or cannot meet it is flagged, see :func:`generate`)
#: and ``seed`` (the one seed rule, :func:`viscore._validate.as_seed`).
COMMON_OPTIONS = ("budget", "seed")


@dataclass(frozen=True)
class GeneratorSpec:
    """A registered generator.

    Attributes
    ----------
    name : str
        CLI name.
    function : callable
        ``(mesh, *, budget, seed, **options) -> Occluder``.
    description : str
        One line for ``--help`` and reports.
    options : tuple of GeneratorOption
        The keyword options beyond ``budget`` and ``seed``.
    conservative : bool
        Whether the method guarantees conservativeness on closed meshes.
    experimental : bool
        Not yet validated; the CLI warns on stderr.
    baseline : bool
        One of the baselines every study includes.
    budgeted : bool
        Whether the triangle budget changes the result (studies run such a
        method once per budget, the others once).
    min_budget : int
        The smallest budget the method can meet (``aabb-skins``: 12, one box);
        smaller budgets are refused by :meth:`check_params` before any work.
    heavy : bool
        Takes a minute or more per mesh on two cores (``hybrid``: its
        metric-guided step casts millions of rays per building). ``viscore
        compare`` leaves such a method out of its culling column, which runs
        it on every building of the city, unless ``--culling-methods`` names
        it.
    """

    name: str
    function: Callable[..., Occluder]
    description: str
    options: tuple[GeneratorOption, ...] = ()
    conservative: bool = False
    experimental: bool = False
    baseline: bool = False
    budgeted: bool = True
    min_budget: int = 1
    heavy: bool = False

    def option(self, name: str) -> GeneratorOption:
        """The declared option called ``name`` (KeyError if none)."""
        for opt in self.options:
            if opt.name == name:
                return opt
        raise KeyError(name)

    def check_params(self, params: dict, *, flags: bool = False) -> dict:
        """Check every parameter against the spec before any work.

        Parameters
        ----------
        params : dict
            Keyword parameters for :attr:`function`: ``budget``, ``seed`` and
            declared options.
        flags : bool, optional
            Name options by their CLI flag in messages (``--max-boxes``).

        Returns
        -------
        dict
            The parameters converted to their declared types.

        Raises
        ------
        InputError
            One line naming the first unknown option (and listing the valid
            ones) or the first value out of type or range.
        """
        known = {o.name: o for o in self.options}
        def name(key: str) -> str:
            return _flag(key) if flags else key
        out = {}
        for key, value in params.items():
            if key == "budget":
                out[key] = None if value is None else as_positive_int(value, name(key))
                if out[key] is not None and self.budgeted and out[key] < self.min_budget:
                    raise InputError(f"{name(key)}: {self.name} needs at least "
                                     f"{self.min_budget} triangles, got {out[key]}")
            elif key == "seed":
                out[key] = as_seed(value, name(key))
            elif key in known:
                out[key] = known[key].check(value, name(key))
            else:
                valid = ", ".join(name(k) for k in (*COMMON_OPTIONS, *known))
                raise InputError(f"{self.name}: unknown option {name(key)} (takes: {valid})")
        return out


REGISTRY: dict[str, GeneratorSpec] = {
    spec.name: spec for spec in [
        GeneratorSpec(
            "aabb-skins", generate_aabb_skins,
            "greedy maximal axis-aligned boxes inside the voxelized mesh (occluder skins)",
            options=(
                GeneratorOption("voxels", int, 64, "voxels along the longest bounding-box side",
                                low=1),
                GeneratorOption("voxel_size", float, None,
                                "voxel side in world units; overrides --voxels",
                                low=0, low_open=True, nullable=True),
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
            options=(
                GeneratorOption("voxels", int, None, "voxels along the longest bounding-box side",
                                low=1, high=PLANAR_MAX_VOXELS, nullable=True,
                                default_text="64 unless --voxel-size or --pixel-error"),
                GeneratorOption("voxel_size", float, None,
                                "voxel side in world units (instead of --voxels)",
                                low=0, low_open=True, nullable=True),
                GeneratorOption("direction_bins", int, PLANAR_DIRECTION_BINS,
                                "bins of plane normals over the hemisphere", low=1, high=256),
                GeneratorOption("depth_bins", int, PLANAR_DEPTH_BINS,
                                "bins of plane depths per direction", low=1, high=64),
                GeneratorOption("alpha", float, PLANAR_ALPHA,
                                "alpha-completeness of the greedy search, percent", low=0),
                GeneratorOption("measure", str, "om",
                                "selection measure: occlusion measure or projected area",
                                choices=("om", "area")),
                GeneratorOption("reduce", str, "om",
                                "budget cut keeps the cut of largest occlusion measure, "
                                "surface area (the paper) or projected area",
                                choices=("area", "projected-area", "om")),
                GeneratorOption("rdp_tolerance", float, PLANAR_RDP_TOLERANCE,
                                "Ramer-Douglas-Peucker tolerance of the edge loops, voxels",
                                low=0, low_open=True),
                GeneratorOption("chain", str, "optimal",
                                "simplification chains: the paper's greedy smallest-ear "
                                "collapse, or with its stages of at most 12 triangles the "
                                "largest inscribed polygons",
                                choices=("optimal", "greedy")),
                GeneratorOption("conservative", bool, False,
                                "slice only through voxels wholly inside the mesh, so that no "
                                "ray sees the occluder before a closed mesh"),
                GeneratorOption("pixel_error", float, None,
                                "screen-space error in pixels that sets the voxel size "
                                "(with --distance or --lod-distances)",
                                low=0, low_open=True, nullable=True),
                GeneratorOption("distance", float, None,
                                "viewer distance of --pixel-error, world units",
                                low=0, low_open=True, nullable=True),
                GeneratorOption("fov", float, PLANAR_FOV, "that viewer's field of view, degrees",
                                low=0, low_open=True, high=180, high_open=True),
                GeneratorOption("screen", int, PLANAR_SCREEN, "that viewer's screen width, pixels",
                                low=1),
                GeneratorOption("lod_distances", str, None,
                                "levels of detail: comma-separated viewer distances, one "
                                "occluder each (with --pixel-error)", nullable=True),
                GeneratorOption("hierarchy", bool, False,
                                "occluder hierarchy over the mesh's parts, with a tree cut per "
                                "camera (sec. 5); writes the tree beside the output"),
                GeneratorOption("dilate", int, 0,
                                "dilation steps of the voxel solid (sec. 5's gluing step)", low=0,
                                high=8),
                GeneratorOption("close", int, None,
                                "close openings up to about 2 x this many voxels wide before the "
                                "flood fill (scans with holes, buildings with open windows)",
                                low=0, high=8, nullable=True,
                                default_text="0, or with the precision floor on and a voxel "
                                "solid without interior (or that closing grows by 10%+) the "
                                "best of 0, 2, 3, 4 on the check views"),
                GeneratorOption("min_precision", float, None,
                                "precision floor: refine the voxels (x sqrt 2, twice at most) "
                                "while the 95% lower bound of the occluder's precision on 64 "
                                "orbit views is under it (coarser while it holds, with the "
                                "default size); 0 turns it off", low=0, high=1, nullable=True,
                                default_text="0.995 unless --voxels, --voxel-size, "
                                "--pixel-error, --conservative or --lod-distances"),
            ),
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
                GeneratorOption("eps_p", float, HYBRID_EPS_P,
                                "metric-guided step: precision gain that removes a face",
                                low=0, high=1),
                GeneratorOption("eps_r", float, HYBRID_EPS_R,
                                "metric-guided step: recall loss below which a face goes",
                                low=0, high=1),
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
                GeneratorOption("voxels", int, 64, "voxels along the longest bounding-box side",
                                low=1, high=2048),
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
        GeneratorSpec("qem", generate_qem, "quadric edge-collapse decimation to the budget",
                      baseline=True),
        GeneratorSpec(
            "godot", generate_godot,
            "Godot 4's occluder bake: meshoptimizer simplify per surface, borders locked",
            options=(
                GeneratorOption("distance", float, None,
                                "bake simplification distance in world units; 0 keeps the mesh",
                                low=0, default_text="1% of the bounding-box diagonal"),
            ),
            baseline=True, budgeted=False),
        GeneratorSpec("bbox", generate_bbox, "the bounding box (non-conservative extreme)",
                      baseline=True, budgeted=False),
        GeneratorSpec("original", generate_original, "the mesh itself (P = R = 1 check)",
                      baseline=True, budgeted=False),
    ]
}


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
        Unknown method or option, or a value out of type or range.

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
    occ = spec.function(mesh, **params)
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
