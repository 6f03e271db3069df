"""Measures: quality metrics, the measures stored with each build, input diagnostics, reports and pictures."""
