"""What a run is, apart from how it runs (imports theory, grid and errors only).

mann      MannRun: from_mapping (run files, presets, requests), to_attrs / from_attrs (stores)
kaimal    KaimalRun, kaimal_params: the same for the Kaimal 4D field
energy    resolve_ae: alpha*eps^(2/3) from ae, sigma_u, TI or an IEC class
defaults  every default of the runs, and "dz defaults to dy"
presets   stability presets (Guo et al. 2023, Tables 1-2)
preset_files  user preset files (TOML/JSON)
preset_runs   what a preset gives a Mann or Kaimal run at a wind speed
config    the one reader of TOML/JSON files (runs, sweeps, presets), checked against turbgen/schemas/
naming    the digest in default store names
"""
