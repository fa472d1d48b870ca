"""Feed-axis plants: what lies beneath the feed-drive block of the force loop.

``velocity_loop``     PWM amplifier, DC motor and tacho (Peng Ch. 2, states I_a and W)
``servo_axis``        velocity loop + ball screw + encoder + force-to-torque + friction
                      (Peng's exact 3-state ZOH block; compiled element ``axis.servo``)
``oscillating_axis``  speed loop + one mechanical oscillator + quantised scale (Briquez;
                      compiled element ``axis.oscillating``)
``friction``          linear, Coulomb + viscous with a stick rule, feed-dependent B
``cutting_load``      the cutting load on an axis: force or torque steps, or samples
``discretisation``    exact zero-order hold (and the step mean) of linear blocks, batched
"""
