"""Tolerance analysis: distributions of the output range and joint loads of a mechanism built with tolerances.

``spec`` (the SPEC file), ``sampling`` (seeded chunks), ``plan`` (what a kind's study needs: the slider
crank's ``slider_crank`` -- its kernel's arrays in ``designs``, its outputs in ``outputs``, exact
derivatives in ``sensitivity`` -- and the RSSR's, RCCC's and loop tables' ``tables``), ``differences``
(the sensitivities' check), ``summary`` (statistics) and ``study`` (the chunks and samples files); run
and judged by :mod:`dualmech.validation.tolerance`; ``docs/conventions.md``, "Tolerance analysis".
"""
