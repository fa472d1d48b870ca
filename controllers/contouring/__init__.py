"""Two-axis contouring: path references, corner blends and contour-error estimation.

``contour_error``   one signed convention for every contour-error estimate: Peng's linear
                    estimate (4.78) (= minus Lacerda & Belo's Eq. 11), the curvature-corrected
                    estimate (Eq. 16, reconstructed), the exact distance to a circle or to a
                    polyline, and the circumcircle of three points; scalar laws compiled for
                    use inside a loop, vectorised wrappers for traces
``interpolator``    path references sampled on the integer clock: line, square and diamond
                    corners (sharp, accel/decel or spline-blended), circle (4.104)/(4.105),
                    sinusoid
``spline_corner``   Peng's cubic-spline corner commands (4.108)-(4.151)
``feedforward``     velocity feed-forward for Peng's axis as a LinuxCNC PID (FF1)
``cross_coupled``   Lacerda & Belo's cross-coupled contour-error controller
``plots``           path overlay with magnified error, polar circle plot, contour error
                    against time

Simulation: :func:`acc.engine.contour_simulate.simulate_contouring` (Peng's two independent
axes on a path, the exact error and the estimates traced) and
:func:`acc.engine.xy_simulate.simulate_xy` (the coupled loop with the cross-coupled
controller).
"""
