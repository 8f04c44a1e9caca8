"""The simulation: the coordinator (``Simulation``) and the stages it steps (MPM, DEM, coupled).

Also what a step is built from: the device clock and the ``Stage`` protocol, launch plans and their
replay, side streams, point sorting, the stages' device state, diagnostics and blow-up checks, and
a settled grain packing (``packing``). Imports the model, ``mpmdem.io`` (to write run files) and
``mpmdem.kernels``; never the study layer or the command line.
"""
