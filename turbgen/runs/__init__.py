"""Execution of one run (turbgen.spec says what a run is): generator -> store, shared by the CLI, the sweep and
the service (bit-identical stores).

mann            run_mann, mann_in_memory, build_mann_stencil, memory_estimate_bytes
mann_outofcore  the same Mann field in two passes through scratch files (a memory budget)
kaimal          run_kaimal, kaimal_in_memory, memory_needed
models          the model registry: name -> spec class, run function, memory estimate
stencil_cache   ae-free Mann stencils (and constrained systems) on disk
scratch         file-backed spectra of Kaimal runs that do not fit in memory
"""
