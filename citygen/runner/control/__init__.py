"""How the baselines move a robot: planning and following paths, and scripted gaits.

- :mod:`~citygen.runner.control.grid`: A* and line of sight on an occupancy grid;
- :mod:`~citygen.runner.control.fields`: geodesic distance fields to a goal;
- :mod:`~citygen.runner.control.regions`: distances to the goal region (SPL's ``L*_best``);
- :mod:`~citygen.runner.control.pursuit`: pure pursuit and reactive avoidance of agents;
- :mod:`~citygen.runner.control.planner`: the navigation baseline built from them;
- :mod:`~citygen.runner.control.gaits`: the quadrupeds' stand and trot;
- :mod:`~citygen.runner.control.gaits_biped`: the humanoid's stand and walk.

The submodules are imported where they are used.
"""
