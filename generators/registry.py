"""The generator registry: the one mapping from CLI names to generators and their options.

Each generator is ``function(mesh, *, budget=..., seed=..., **options) -> Occluder``.
Its :class:`GeneratorSpec` declares the options beyond ``budget`` and ``seed``
(:class:`GeneratorOption`: name, type, default, range, choices, help); the
command line builds ``viscore generate METHOD`` and its flags from them, and
:func:`generate` checks every value against them before any work. A new method
is one module plus one entry in :data:`REGISTRY`: it then appears in
``viscore generate --help`` and joins every study, with no change under ``cli/``.

Plugins: another installed distribution adds methods under the entry-point
group ``viscore.generators`` (:data:`PLUGIN_GROUP`), each naming either a
:class:`GeneratorSpec` or a plain function ``f(mesh, *, budget, seed,
**options)`` returning an :class:`Occluder` or a :class:`trimesh.Trimesh`
(:meth:`GeneratorSpec.from_function` turns it into a spec). They are
discovered once, on the first access to :data:`REGISTRY` (so importing the
package stays cheap), unless ``VISCORE_NO_PLUGINS=1``. A plugin that cannot
be loaded, or whose name is taken, costs one warning line and is left out.
:func:`generate` validates a plugin's input mesh before calling it and its
output after (:class:`PluginError`).

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

import ast
import dataclasses
import importlib.metadata
import inspect
import logging
import math
import numbers
import os
import threading
import time
import types
import typing
from collections.abc import Callable, Iterator, MutableMapping
from dataclasses import dataclass

import numpy as np
import trimesh

from viscore import InputError, validate_mesh
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
from .occluder import Occluder, check_parts
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
from .surface_patches import generate_surface_patches
from .surface_patches.generator import MIN_AREA as SURFACE_MIN_AREA
from .surface_patches.generator import PLANE_TOLERANCE as SURFACE_PLANE_TOLERANCE

__all__ = ["GeneratorOption", "GeneratorSpec", "REGISTRY", "get_generator", "generate",
           "COMMON_OPTIONS", "MethodVariant", "parse_method", "PluginError", "PLUGIN_GROUP",
           "plugin_versions"]

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
    plugin : tuple of (str, str), optional
        ``(distribution, version)`` of the installed package that registered
        the method through the ``viscore.generators`` entry points (``None``:
        one of the toolkit's own). Set by discovery, not by the plugin.
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
    plugin: tuple[str, str] | None = None

    @classmethod
    def from_function(cls, function: Callable, name: str | None = None, *,
                      description: str | None = None) -> GeneratorSpec:
        """The spec of a plain function ``f(mesh, *, budget, seed, **options)``.

        Parameters
        ----------
        function : callable
            Takes the mesh as its first positional parameter and returns an
            :class:`Occluder` or a :class:`trimesh.Trimesh` (whose
            ``metadata["conservative_guaranteed"]`` and
            ``metadata["double_sided"]``, when present, are taken as the
            method's claim and drawing mode; double-sided by default).
            Its keyword-only parameters with defaults, other than ``budget``
            and ``seed``, become the options: the type from the default
            (``int``, ``float``, ``str``, ``bool``) or, for a ``None``
            default, from the annotation (``int | None``; a
            ``Literal['a', 'b']`` annotation gives the choices); the help
            from the numpydoc Parameters section of its docstring.
        name : str, optional
            The method's name; default the function's ``__name__`` with
            dashes for underscores.
        description : str, optional
            Default: the first line of the docstring.

        Returns
        -------
        GeneratorSpec
            Its :attr:`function` calls ``function`` with ``budget`` (None
            when not given) and ``seed`` (0 when not given) when it takes
            them, and wraps a returned mesh in an :class:`Occluder`.
            ``budgeted`` is whether ``function`` takes a ``budget``.

        Raises
        ------
        TypeError
            ``function`` is not callable, takes no mesh, has a required
            parameter the toolkit cannot fill, or an option whose type
            cannot be told.

        Examples
        --------
        >>> import trimesh
        >>> def shrunk(mesh, *, budget=None, seed=0, scale: float = 0.5):
        ...     '''Shrunk copy of the mesh.'''
        ...     return mesh.copy().apply_scale(scale)
        >>> spec = GeneratorSpec.from_function(shrunk)
        >>> spec.name, [o.name for o in spec.options], spec.options[0].type.__name__
        ('shrunk', ['scale'], 'float')
        >>> spec.function(trimesh.creation.box(), scale=0.25).triangles
        12
        """
        return _spec_from_function(function, name, description)

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


REGISTRY: MutableMapping[str, GeneratorSpec] = _Registry({
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
        GeneratorSpec(
            "surface-patches", generate_surface_patches,
            "double-sided polygons cut from the input's own coplanar regions (across loose "
            "parts), chosen by occlusion measure; conservative on any input (thin, open game "
            "geometry)",
            options=(
                GeneratorOption("plane_tolerance", float, SURFACE_PLANE_TOLERANCE,
                                "coplanarity tolerance: largest distance of a region face's "
                                "vertex from its plane, fraction of the bounding-box diagonal",
                                low=0, low_open=True, high=1e-5),
                GeneratorOption("min_area", float, SURFACE_MIN_AREA,
                                "skip regions and pieces under this fraction of the input's "
                                "face area", low=0, high=1),
                GeneratorOption("chain", str, "optimal",
                                "stages of at most 12 triangles: largest inscribed polygons or "
                                "the paper's greedy chain", choices=("optimal", "greedy")),
            ),
            conservative=True, min_budget=1),
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


# --------------------------------------------------------------------------- plugins

#: The entry-point group other distributions register methods under.
PLUGIN_GROUP = "viscore.generators"

#: Set to 1 (or true, yes) to leave the plugins out.
_NO_PLUGINS_ENV = "VISCORE_NO_PLUGINS"

#: Version recorded for a plugin whose entry point has no distribution.
_UNKNOWN = "unknown"


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
    try:
        obj = ep.load()
    except Exception as exc:  # noqa: BLE001 - any failure of a plugin's import is its own
        raise _PluginProblem(f"cannot be loaded: {type(exc).__name__}: {exc}") from None
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


def _occluder_from(result, name: str, params: dict, seconds: float):
    """``result`` as an :class:`Occluder`: a mesh is wrapped, anything else returned as is."""
    if not isinstance(result, trimesh.Trimesh):
        return result
    meta = result.metadata if isinstance(result.metadata, dict) else {}
    info = {}
    if meta.get("conservative_guaranteed") is not None:
        info["conservative_guaranteed"] = bool(meta["conservative_guaranteed"])
    return Occluder(mesh=result, method=name, params=dict(params),
                    double_sided=bool(meta.get("double_sided", True)), seconds=float(seconds),
                    info=info)


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

#: Option types from a default value, most specific first (a bool is an int).
_DEFAULT_TYPES = (bool, int, float, str)


class _FunctionGenerator:
    """A plain function as a generator: ``budget``/``seed`` passed when taken, mesh wrapped.

    Its ``__signature__`` is the generator signature (``mesh, *, budget,
    seed, options...``) so that it reads like one of the toolkit's own.
    """

    def __init__(self, function: Callable, name: str, options: tuple[GeneratorOption, ...],
                 takes_budget: bool, takes_seed: bool) -> None:
        self.function = function
        self.name = name
        self._defaults = {o.name: o.default for o in options}
        self._takes_budget = takes_budget
        self._takes_seed = takes_seed
        kw = inspect.Parameter.KEYWORD_ONLY
        self.__signature__ = inspect.Signature(
            [inspect.Parameter("mesh", inspect.Parameter.POSITIONAL_OR_KEYWORD),
             inspect.Parameter("budget", kw, default=None),
             inspect.Parameter("seed", kw, default=0),
             *(inspect.Parameter(o.name, kw, default=o.default) for o in options)])
        self.__name__ = getattr(function, "__name__", name)
        self.__qualname__ = getattr(function, "__qualname__", self.__name__)
        self.__module__ = getattr(function, "__module__", None)
        self.__doc__ = getattr(function, "__doc__", None)

    def __call__(self, mesh, *, budget=None, seed=0, **options) -> Occluder:
        kwargs = dict(options)
        if self._takes_budget:
            kwargs["budget"] = budget
        if self._takes_seed:
            kwargs["seed"] = seed
        start = time.perf_counter()
        result = self.function(mesh, **kwargs)
        params = {"budget": budget, "seed": seed, **self._defaults, **options}
        return _occluder_from(result, self.name, params, time.perf_counter() - start)

    def __repr__(self) -> str:
        return f"<generator {self.name!r} from {self.__module__}.{self.__qualname__}>"


def _spec_from_function(function, name, description) -> GeneratorSpec:
    if not callable(function):
        raise TypeError(f"expected a function, got a {type(function).__name__}")
    label = name or getattr(function, "__name__", "").replace("_", "-")
    if not label:
        raise TypeError("a method name is needed for a function without __name__")
    try:
        sig = inspect.signature(function, eval_str=True)
    except Exception:  # noqa: BLE001 - unresolvable annotations: read them as text
        try:
            sig = inspect.signature(function)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{label}: cannot read the signature ({exc})") from None
    params = list(sig.parameters.values())
    P = inspect.Parameter
    var_kw = any(p.kind is P.VAR_KEYWORD for p in params)
    if not params or params[0].kind not in (P.POSITIONAL_ONLY, P.POSITIONAL_OR_KEYWORD,
                                            P.VAR_POSITIONAL):
        raise TypeError(f"{label}: the first parameter must be the mesh, positional")
    docs = _numpydoc_parameters(inspect.getdoc(function))
    options = []
    for p in params[1:]:
        if p.kind in (P.VAR_POSITIONAL, P.VAR_KEYWORD):
            continue
        if p.name in COMMON_OPTIONS:
            if p.kind is P.POSITIONAL_ONLY:
                raise TypeError(f"{label}: {p.name} must be a keyword parameter")
            continue
        if p.default is P.empty:
            raise TypeError(f"{label}: parameter {p.name!r} has no default "
                            "(options need one)")
        if p.kind is P.KEYWORD_ONLY:
            options.append(_option_from_parameter(label, p, docs.get(p.name)))
    names = {p.name for p in params}
    takes_budget = "budget" in names or var_kw
    takes_seed = "seed" in names or var_kw
    options = tuple(options)
    doc = inspect.getdoc(function) or ""
    summary = doc.strip().splitlines()[0].strip() if doc.strip() else ""
    return GeneratorSpec(
        label, _FunctionGenerator(function, label, options, takes_budget, takes_seed),
        description or summary or f"{label} (a plain-function generator)",
        options=options, budgeted=takes_budget)


def _option_from_parameter(label: str, p: inspect.Parameter, doc: str | None) -> GeneratorOption:
    default = p.default
    annotated, nullable, choices = _annotation_type(p.annotation)
    if default is None:
        if annotated is None:
            raise TypeError(f"{label}: option {p.name!r} defaults to None without an "
                            "annotation saying its type (int | None, float | None, ...)")
        kind, nullable = annotated, True
    else:
        kind = next((t for t in _DEFAULT_TYPES if isinstance(default, t)), None)
        if kind is None:
            raise TypeError(f"{label}: option {p.name!r} has a default of type "
                            f"{type(default).__name__}; options are int, float, str or bool")
        if annotated is float and kind is int:
            kind, default = float, float(default)
        elif annotated is not None and annotated is not kind:
            raise TypeError(f"{label}: option {p.name!r} is annotated {annotated.__name__} "
                            f"but defaults to {default!r}")
        if kind is float:
            default = float(default)
    if choices is not None and (kind is not str or (default is not None
                                                    and default not in choices)):
        raise TypeError(f"{label}: option {p.name!r}: its default {default!r} is not one of "
                        f"its choices {choices}")
    help_text = doc or p.name.replace("_", " ")
    return GeneratorOption(p.name, kind, default, help_text, choices=choices,
                           nullable=nullable)


def _annotation_type(annotation) -> tuple[type | None, bool, tuple[str, ...] | None]:
    """``(type, nullable, choices)`` an annotation says; ``(None, False, None)`` if unknown."""
    if annotation is inspect.Parameter.empty:
        return None, False, None
    if isinstance(annotation, str):
        return _annotation_text(annotation)
    if annotation in _TYPES:
        return annotation, False, None
    origin = typing.get_origin(annotation)
    if origin is typing.Literal:
        values = typing.get_args(annotation)
        if values and all(isinstance(v, str) for v in values):
            return str, False, tuple(values)
        return None, False, None
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        nullable = len(args) < len(typing.get_args(annotation))
        if len(args) == 1:
            kind, _, choices = _annotation_type(args[0])
            return kind, nullable, choices
        if set(args) == {int, float}:
            return float, nullable, None
    return None, False, None


def _annotation_text(text: str) -> tuple[type | None, bool, tuple[str, ...] | None]:
    """The same from an annotation left as text (``from __future__ import annotations``)."""
    text = text.strip()
    if text.startswith("Optional[") and text.endswith("]"):
        kind, _, choices = _annotation_text(text[len("Optional["):-1])
        return kind, True, choices
    parts = [t.strip() for t in text.split("|")]
    nullable = "None" in parts
    parts = [t for t in parts if t != "None"]
    if len(parts) != 1:
        return (float, nullable, None) if sorted(parts) == ["float", "int"] else (None, False,
                                                                                  None)
    word = parts[0].removeprefix("typing.")
    if word.startswith("Literal[") and word.endswith("]"):
        try:
            values = ast.literal_eval("(" + word[len("Literal["):-1] + ",)")
        except (ValueError, SyntaxError):
            return None, False, None
        if values and all(isinstance(v, str) for v in values):
            return str, nullable, tuple(values)
        return None, False, None
    kind = {"int": int, "float": float, "str": str, "bool": bool}.get(word)
    return kind, nullable and kind is not None, None


def _numpydoc_parameters(doc: str | None) -> dict[str, str]:
    """``{name: help}`` from a numpydoc Parameters section: each first paragraph, one line."""
    lines = inspect.cleandoc(doc or "").splitlines()
    start = next((i + 2 for i in range(len(lines) - 1) if lines[i].strip() == "Parameters"
                  and set(lines[i + 1].strip()) == {"-"}), None)
    if start is None:
        return {}
    out: dict[str, list[str]] = {}
    names: list[str] = []
    ended = False  # the first paragraph of the current entry has ended
    for i in range(start, len(lines)):
        line = lines[i]
        following = lines[i + 1].strip() if i + 1 < len(lines) else ""
        if line.strip() and not line[0].isspace():
            if following and set(following) == {"-"}:
                break  # the next section
            names = [n.strip().lstrip("*") for n in line.split(":", 1)[0].split(",")]
            for n in names:
                out[n] = []
            ended = False
        elif not line.strip():
            ended = ended or any(out[n] for n in names)
        elif names and not ended:
            for n in names:
                out[n].append(line.strip())
    return {name: " ".join(words) for name, words in out.items() if words}


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
