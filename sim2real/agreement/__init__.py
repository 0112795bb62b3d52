"""The agreement workflow: replay a real log in simulation and measure how well it matches.

Modules, in the order a run uses them:

- :mod:`~sim2real.agreement.replay` drives a simulated base (pybullet or the reduced model)
  with a log's commands at their logged times;
- :mod:`~sim2real.agreement.figures` measures the agreement of a replay with the real
  velocities, the ensemble band and its coverage;
- :mod:`~sim2real.agreement.calibration` fits the spread of a params file's randomisation to a
  log the fit did not use;
- :mod:`~sim2real.agreement.study` runs the whole ``sim2real agree`` job and writes its outputs.

May import :mod:`robots`, :mod:`sysid`, :mod:`sim2real.logs` and :mod:`sim2real.agreement.report`; never
the CLI, the training code or the envs.
"""
