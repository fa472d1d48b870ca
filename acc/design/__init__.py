"""Design tools: the loop as python-control objects (:mod:`~acc.design.linear`), margins and
stability boundaries (:mod:`~acc.design.analysis`), their figures
(:mod:`~acc.design.loop_plots`), tuning and controller comparisons.  :mod:`acc.analysis`
gathers the first three for notebooks."""
