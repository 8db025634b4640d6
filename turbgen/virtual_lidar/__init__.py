"""Lidars on turbgen fields: descriptions, preview theory, line-of-sight sampling, signals, verdict, runs."""
