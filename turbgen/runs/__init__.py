"""Execution of one run (turbgen.spec says what a run is): generator -> store, shared by the CLI, the sweep and
the service (bit-identical stores); the model registry is turbgen.runs.models."""
