"""Tests of the judges (validation/judges/): each judge's own in its folder, those of several here."""
