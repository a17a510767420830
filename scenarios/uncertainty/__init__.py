"""Monte-Carlo uncertainty of manoeuvre metrics from the identified coefficient covariance.

An identification returns θ̂ and its covariance Σ (params.json). This package draws
coefficient sets θ ~ N(θ̂, Σ), drives every sample through the manoeuvre programs
(turning circles, zig-zags) and summarises each metric by its value at θ̂, the mean,
the standard deviation and the 2.5 % and 97.5 % quantiles of the samples:

    θ_i = θ̂ + S z_i,   z_i ~ N(0, I),   S Sᵀ = Σ   (i = 1 … N),

with S from a Cholesky factorisation of the correlation matrix of the coefficients that
have a positive variance (a small jitter on its diagonal when it is only
semi-definite); coefficients with zero variance stay exactly at θ̂.

The samples are simulated in chunks: each chunk is one task on a ``dask.distributed``
cluster (a ``LocalCluster`` made for the call by default), and inside a task the
chunk's ships advance together through the one programme runner
(``trials.run.run_batch`` on a batch ``ModelPlant``: one vectorised RK4 step for all of
them, steering gear at a constant rate, legs ended by time or by the heading change
since execute, so every zig-zag sample reverses its rudder at its own times). The
trajectories go to the usual ``trials.metrics`` functions.

A sample *fails* for a program when its ship diverges (non-finite state, speed over
ground above ``divergence_factor`` × U or yaw rate above ``divergence_factor`` × U/L)
or when the metrics cannot be computed (the heading does not reach 90°/180° or the
check heading, or the ship turns against its rudder). Failed samples are counted and
reported, never raised; the statistics are over the remaining samples.

Modules, one job each:

- :mod:`scenarios.uncertainty.sampling`: the draw θ ~ N(θ̂, Σ) (``draw_coefficients``);
- :mod:`scenarios.uncertainty.results`: the result records (``MetricSummary``,
  ``ProgramUncertainty``, ``UncertaintyResult``), the metrics per program kind and the
  sample statuses;
- :mod:`scenarios.uncertainty.monte_carlo`: the samples through the programs on a dask
  cluster (``monte_carlo_metrics``).

The command line ``python -m scenarios uncertainty`` is in :mod:`scenarios.cli.uncertainty`.
"""
