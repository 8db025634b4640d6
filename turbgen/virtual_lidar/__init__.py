"""Lidars on turbgen fields: what a lidar is (description, presets, files) and the virtual lidar on stores.

Modules
-------
description  lidar description, presets and lidar files
preview      (lidar-theory) preview quantities of a description
sampling     line-of-sight speeds sampled from a store along the beams (probe volume, scan timing)
signals      lidar estimate u_LL, rotor-averaged u_RR, lidar TI, Welch coherence gamma^2_RL
compare      simulated gamma^2_RL against theory (validator verdict), MCB and cut-off of curves
run          one virtual-lidar run on a store
dataset      the lidar output dataset (zarr, xarray-readable), written atomically
"""
