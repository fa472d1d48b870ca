"""The simulation engine: the element protocol, the compiled loops, simulate() and results.

``acc.engine.element``   the protocol every compiled element follows (records, jit, dispatch)
``acc.engine.rng``       counter-based normal streams drawn inside compiled code
``acc.engine.force_loop`` the closed cutting-force loop, compiled
``acc.engine.simulate``  scenarios in, :class:`~acc.engine.result.SimulationResult` out
"""
