"""Values and expressions that users type, read without ``eval`` (the former home of both;
kept so that ``astrocpg.models.values`` imports keep working).

Values with units and the command line's numbers live in ``units.py`` (:func:`parse_value`,
:func:`unit_spelling`, :func:`example_value`, :func:`finite_number`, :func:`whole_steps`);
the safe compiler of model expressions in ``expressions.py`` (:func:`compile_expression`,
:data:`FUNCTIONS`).
"""

from __future__ import annotations

from .expressions import FUNCTIONS, compile_expression
from .units import UNITS, example_value, finite_number, parse_value, unit_spelling, whole_steps

__all__ = ["parse_value", "unit_spelling", "example_value", "finite_number", "whole_steps",
           "compile_expression", "UNITS", "FUNCTIONS"]
