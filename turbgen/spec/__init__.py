"""What a run is, apart from how it runs (imports theory, grid and errors only): run classes (MannRun, KaimalRun)
from run files, presets and requests, their defaults, presets, mean wind and constraint files."""
