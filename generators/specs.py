"""What a method is to the toolkit: its options and its spec, and a spec from a plain function."""

from __future__ import annotations

import ast
import functools
import inspect
import logging
import math
import numbers
import time
import types
import typing
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import trimesh

from viscore import InputError
from viscore._validate import as_positive_int, as_seed

from .occluder import Occluder

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
    convert : callable, optional
        ``convert(value, label)``: the generator's own reading of a value
        that is not one type (a ground height or ``'auto'``/``'off'``;
        distances as text or numbers), returning what the generator works
        with or raising :class:`~viscore.InputError`. It replaces the
        type, range and choices checks: :meth:`check` keeps a value it
        accepts as given (so a method variant's text stays as written),
        :meth:`read` returns its conversion.
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
    convert: Callable[[object, str], object] | None = None

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
        """``value`` converted to the option's type, or :class:`InputError` naming ``label``.

        A ``bool`` is ``True`` or ``False`` (numpy's included); an option with
        :attr:`convert` keeps every value its conversion accepts as given.
        """
        label = label or self.name
        if value is None and self.nullable:
            return None
        if self.convert is not None:
            self.convert(value, label)
            return value
        bad = InputError(f"{label}: expected {self.expected()}, got {value!r}")
        if self.type is bool:
            if not isinstance(value, (bool, np.bool_)):
                raise bad
            return bool(value)
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

    def read(self, value: object, label: str | None = None) -> object:
        """``value`` as the generator works with it: :meth:`check`'s, or :attr:`convert`'s."""
        if self.convert is None or (value is None and self.nullable):
            return self.check(value, label)
        return self.convert(value, label or self.name)

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

_Generator = TypeVar("_Generator", bound=Callable[..., Occluder])


def check_arguments(options: Sequence[GeneratorOption], arguments: dict) -> dict:
    """A generator's keyword arguments checked and converted by its declared options.

    ``budget`` is None or an integer >= 1, ``seed`` the one seed rule
    (:func:`viscore._validate.as_seed`), each declared option
    :meth:`GeneratorOption.read` (an option left at a ``None`` default, one the
    generator computes from the mesh, stays None); other keys pass as they are.

    Raises
    ------
    InputError
        The first value out of type or range, in the order ``budget``,
        ``seed``, then the options as declared.
    """
    out = dict(arguments)
    if out.get("budget") is not None:
        out["budget"] = as_positive_int(out["budget"], "budget")
    if "seed" in out:
        out["seed"] = as_seed(out["seed"], "seed")
    for option in options:
        if option.name in out and not (out[option.name] is None and option.default is None):
            out[option.name] = option.read(out[option.name])
    return out


def checked_by(options: Sequence[GeneratorOption]) -> Callable[[_Generator], _Generator]:
    """Decorator: a generator whose arguments are checked by its declared options first.

    The options a method declares (for the registry's :class:`GeneratorSpec`
    and the command line's flags) are the checks of its generator too: the
    wrapped generator gets ``budget``, ``seed`` and every declared option
    checked and converted (:func:`check_arguments`, defaults included)
    before its body runs, so that its body holds only its rules across
    options and its work. The wrapper keeps the generator's name, signature
    and docstring; it never touches the mesh (a check-only call,
    :func:`check_only_call`, still ends at the body's first use of it).

    Parameters
    ----------
    options : sequence of GeneratorOption
        One per keyword-only parameter of the generator besides ``budget``
        and ``seed``, with the parameter's default.

    Raises
    ------
    TypeError
        At decoration, when the options and the generator's keyword-only
        parameters or their defaults disagree.

    Examples
    --------
    >>> SIDE = (GeneratorOption("side", float, 1.0, "side, world units", low=0, low_open=True),)
    >>> @checked_by(SIDE)
    ... def shrunk(mesh, *, budget=None, seed=0, side=1.0):
    ...     return side
    >>> shrunk(None, side=2)
    2.0
    >>> try:
    ...     shrunk(None, side=-1)
    ... except InputError as exc:
    ...     print(exc)
    side: expected a number > 0, got -1
    """
    options = tuple(options)

    def decorate(function: _Generator) -> _Generator:
        signature = inspect.signature(function)
        params = signature.parameters
        keywords = {k for k, p in params.items() if p.kind is inspect.Parameter.KEYWORD_ONLY}
        declared = {o.name for o in options}
        if keywords - set(COMMON_OPTIONS) != declared:
            raise TypeError(f"{function.__name__}: options declared {sorted(declared)}, "
                            f"keyword options {sorted(keywords - set(COMMON_OPTIONS))}")
        for option in options:
            if params[option.name].default != option.default:
                raise TypeError(f"{function.__name__}: option {option.name} declares the "
                                f"default {option.default!r}, the generator has "
                                f"{params[option.name].default!r}")
        first = next(iter(params))

        @functools.wraps(function)
        def checked(*args, **kwargs):
            bound = signature.bind(*args, **kwargs)
            bound.apply_defaults()
            arguments = dict(bound.arguments)
            mesh = arguments.pop(first)
            return function(mesh, **check_arguments(options, arguments))

        checked.options = options  # type: ignore[attr-defined]
        return checked  # type: ignore[return-value]

    return decorate


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
    inputs : {'any', 'height-fields'}
        The meshes the method is for: ``any``, or ``height-fields`` (open
        ground seen once from below: terrain, floors; ``terrain-drape``).
        ``viscore compare`` runs the latter only when ``--methods`` names them.
    plugin : tuple of (str, str), optional
        ``(distribution, version)`` of the installed package that registered
        the method through the ``viscore.generators`` entry points (``None``:
        one of the toolkit's own). Set by discovery, not by the plugin.
    checker : callable, optional
        ``checker(**params)`` runs the method's own argument checks on
        checked parameters without doing any work, raising
        :class:`~viscore.InputError` on a conflict
        (:meth:`check_options`). The toolkit's own methods have
        :func:`check_only` of their function (a generator that checks its
        arguments before it touches the mesh); default ``None``, no check
        beyond :meth:`check_params` (a method of another package may set
        its own).
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
    inputs: str = "any"
    plugin: tuple[str, str] | None = None
    checker: Callable[..., None] | None = None

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
                if out[key] is not None and self.budgeted and out[key] < self.min_budget:  # type: ignore[operator]
                    raise InputError(f"{name(key)}: {self.name} needs at least "
                                     f"{self.min_budget} triangles, got {out[key]}")
            elif key == "seed":
                out[key] = as_seed(value, name(key))
            elif key in known:
                out[key] = known[key].check(value, name(key))  # type: ignore[assignment]
            else:
                valid = ", ".join(name(k) for k in (*COMMON_OPTIONS, *known))
                raise InputError(f"{self.name}: unknown option {name(key)} (takes: {valid})")
        return out

    def check_options(self, params: dict) -> dict:
        """Every check the method makes on ``params`` before its work, without the work.

        First :meth:`check_params` (types and ranges), then the method's own
        rules across options, by :attr:`checker` when the spec has one (the
        toolkit's own methods: a check-only call of the generator,
        :func:`check_only`). Checks that need the mesh (its size against a
        voxel grid's memory) are the generator's, when it runs.

        Parameters
        ----------
        params : dict
            Keyword parameters for :attr:`function` (``budget``, ``seed`` and
            declared options); missing ones take the generator's defaults.

        Returns
        -------
        dict
            The parameters converted to their declared types.

        Raises
        ------
        InputError
            The first value out of type or range, or the method's own message
            on options that conflict (``pixel_error: needs distance``).

        Examples
        --------
        >>> from viscore.generators import REGISTRY
        >>> spec = REGISTRY["planar-sections"]
        >>> spec.check_options({"close": 2})
        {'close': 2}
        >>> try:
        ...     spec.check_options({"voxels": 32, "voxel_size": 0.1})
        ... except InputError as exc:
        ...     print(exc)
        voxels and voxel_size: give one way of sizing the voxels
        """
        params = self.check_params(params)
        if self.checker is not None:
            self.checker(**params)
        return params


class _ChecksPassed(BaseException):
    """A generator under :func:`check_only_call` reached its mesh: its checks passed.

    A :class:`BaseException`, so that no ``except Exception`` of a generator
    takes it for a failure of its own and carries on working.
    """


class _CheckOnlyMesh(trimesh.Trimesh):
    """A stand-in mesh that ends a check-only call at its first use.

    It passes ``isinstance(mesh, trimesh.Trimesh)``; reading any of its
    attributes (``faces``, ``vertices``, ``bounds``, ``metadata``, a method)
    raises :class:`_ChecksPassed`, as do the special methods ``trimesh``
    defines (they read attributes), so the generator stops where its work
    would begin.
    """

    def __init__(self) -> None:  # no geometry, nothing of Trimesh's state
        pass

    def __getattribute__(self, name: str):
        if name == "__class__":  # isinstance
            return object.__getattribute__(self, name)
        raise _ChecksPassed(name)


def check_only(function: Callable) -> Callable[..., None]:
    """A :attr:`GeneratorSpec.checker` that is a check-only call of ``function``.

    For a generator that checks all its arguments before it first uses the
    mesh, as the toolkit's own do (:func:`check_only_call`).
    """
    def checker(**params) -> None:
        check_only_call(function, params)
    checker.__name__ = f"check_only({getattr(function, '__name__', 'generator')})"
    return checker


def check_only_call(function: Callable, params: dict) -> bool:
    """Run ``function(mesh, **params)`` up to its first use of the mesh: its checks, no work.

    The generator gets a stand-in :class:`trimesh.Trimesh` whose first use
    ends the call, so whatever it checks before it touches the mesh (every
    rule across its options, for the toolkit's generators) runs exactly as
    in a real call, and nothing after.

    Parameters
    ----------
    function : callable
        A generator ``function(mesh, *, budget, seed, **options)``.
    params : dict
        Its keyword parameters.

    Returns
    -------
    bool
        True when the call reached the mesh (every check before it passed);
        False when it ended otherwise without an :class:`~viscore.InputError`
        (returned, or failed on the stand-in in a way only a real mesh
        avoids: the checks are then left to the real call).

    Raises
    ------
    InputError
        The generator's own refusal of ``params``.

    Examples
    --------
    >>> from viscore import InputError
    >>> def method(mesh, *, budget=None, seed=0, side=1.0):
    ...     if side <= 0:
    ...         raise InputError("side: expected a positive length")
    ...     return mesh.copy()  # the work: never reached
    >>> check_only_call(method, {"side": 2.0})
    True
    >>> try:
    ...     check_only_call(method, {"side": -1.0})
    ... except InputError as exc:
    ...     print(exc)
    side: expected a positive length
    """
    try:
        function(_CheckOnlyMesh(), **params)
    except _ChecksPassed:
        return True
    except InputError:
        raise
    except Exception:  # noqa: BLE001 - a use of the stand-in only a real mesh survives
        _log.debug("check-only call of %r ended before the mesh", function, exc_info=True)
        return False
    return False



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
        self.__module__ = getattr(function, "__module__", None)  # type: ignore[assignment]
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
