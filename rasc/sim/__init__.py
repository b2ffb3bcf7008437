"""The simulated stereo head: the MuJoCo model (``models/``, shipped as package data),
offscreen rendering and image degradation (:mod:`~rasc.sim.scene`, the only module that
imports mujoco, lazily) and dataset rendering (:mod:`~rasc.sim.render`)."""
