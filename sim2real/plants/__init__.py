"""Foreign plants: simulated bases whose physics is *not* the project's drive model.

They stand in for real robots when a tool has to be judged on data its own model did not
produce:

- :mod:`~sim2real.plants.diff_drive`: a differential drive with PI wheel loops, a DC motor's
  torque-speed line, battery sag, quantised encoders and command latency; fleets of sessions;
- :mod:`~sim2real.plants.skid`: a four-wheel skid steer whose slip comes out of tyre forces;
- :mod:`~sim2real.plants.closed_loop`: the differential drive stepped one command at a time
  (the envs' ``dynamics="plant"``) and the sessions it is drawn from.
- :mod:`~sim2real.plants.recording`: a command script played on a plant session, as one call.

May import :mod:`robots` and :mod:`sim2real.logs`; nothing that fits or measures.
"""
