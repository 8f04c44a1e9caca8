"""The model: what a run is made of, described on the host before any kernel runs (SI units).

The scene (the builder) and its checks, the finished ``Model`` it ends in (``Scene.finalize``),
the shapes of MPM bodies and the spheropolygons of DEM bodies, rigid bodies and grain sets,
materials (elastic and granular), boundaries, mass probes, and the frozen ``SolverConfig`` that
picks the kernel variants. Imports only the base (``mpmdem.errors``, ``mpmdem.checks``) and
``mpmdem.kernels`` (constants the config and materials validate against).
"""
