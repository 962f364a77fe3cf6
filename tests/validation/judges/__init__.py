"""Tests of the judges generated from loop tables (validation/judges/)."""
