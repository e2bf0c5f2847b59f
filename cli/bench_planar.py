"""Former path of :mod:`viscore.cli.bench.planar`, kept while tests/test_planar_sections.py
and generators/planar_sections.py name it; remove when they name the new module."""

from .bench.planar import *  # noqa: F403
from .bench.planar import __all__  # noqa: F401
