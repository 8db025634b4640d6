"""Lidars on turbgen fields: descriptions, presets and files (description), preview theory (preview), line-of-sight
sampling of stores (sampling), u_LL/u_RR signals and Welch coherence (signals), the verdict against theory
(compare, report), one run (run) and its output dataset (dataset).
"""
