"""Tests of the generated judges on the preset mechanisms (validation/judges/presets/)."""
