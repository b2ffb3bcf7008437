"""The simulated stereo head: the MuJoCo model (``models/``, shipped as package data),
offscreen rendering and image degradation (:mod:`~rasc.sim.scene`, the only module that
imports mujoco, lazily) and dataset rendering (:mod:`~rasc.sim.render`)."""


def __getattr__(name: str):
    """Names the old module ``rasc.sim`` had: forwarded with a DeprecationWarning."""
    from rasc import moved_attribute

    return moved_attribute(__name__, name)
