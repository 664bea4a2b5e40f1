"""Diagnosis: calibrate the twin to a measurement, show where it fails, name the missing effect.

The steps (docs/diagnosis.md §1) each live in their own module; :func:`diagnose` runs them.
"""
