"""Figures of results (matplotlib) and the models rendered for people (sympy equations and
parameter tables)."""
