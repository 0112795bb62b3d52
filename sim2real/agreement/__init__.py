"""The agreement workflow: replay a real log in simulation and measure how well it matches.

Modules, in the order a run uses them:

- :mod:`~sim2real.agreement.replay` drives a simulated base (pybullet or the reduced model)
  with a log's commands at their logged times;
- :mod:`~sim2real.agreement.figures` measures the agreement of a replay with the real
  velocities, the ensemble band and its coverage;
- :mod:`~sim2real.agreement.sources` measures where a band's width and its misses come from
  (the noise, the command latency, each parameter's spread);
- :mod:`~sim2real.agreement.calibration` fits the spread of a params file's randomisation to a
  log the fit did not use;
- :mod:`~sim2real.agreement.verdict` decides, once, what an agreement run means and what to do
  next (the CLI and the report print its words);
- :mod:`~sim2real.agreement.report` draws the HTML page and plots of a run;
- :mod:`~sim2real.agreement.study` runs the whole ``sim2real agree`` job and writes its outputs.

May import :mod:`robots`, :mod:`sysid`, :mod:`randomizers` (the ensemble's random streams) and
:mod:`sim2real.logs`; never the CLI, the training code, the envs or :mod:`sim2real.cluster`
(which fans :mod:`~sim2real.agreement.study` out over many logs).
"""
