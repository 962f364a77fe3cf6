"""Tolerance analysis: distributions of the stroke and joint loads of a mechanism built with tolerances.

``spec`` (the SPEC file), ``sampling`` (seeded chunks), ``outputs`` (per design), ``sensitivity``
(exact derivatives at the nominal design), ``summary`` (statistics), ``judges`` (spot checks by
Pinocchio and MuJoCo) and ``study`` (the whole run); ``docs/conventions.md``, "Tolerance analysis".
"""
