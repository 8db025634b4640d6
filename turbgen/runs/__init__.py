"""One run = generator -> store, shared by the CLI and the sweep (so both give bit-identical stores).

mann      MannRun, build_mann_stencil, run_mann (Mann space-time field, issue 3)
kaimal    KaimalRun, run_kaimal (Kaimal field with longitudinal coherence, issue 4)
config    reading a --config TOML/JSON file and validating it against turbgen/schemas/
defaults  the paper defaults (DEFAULT_PLANES_M, MANN_DEFAULTS, MANN_GRID)
"""
