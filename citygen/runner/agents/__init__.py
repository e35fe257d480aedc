"""The moving agents of a scene, simulated (never stored): people and vehicles.

- :mod:`~citygen.runner.agents.orca`: ORCA's velocities for every agent at once (RVO2's
  linear programs as array operations);
- :mod:`~citygen.runner.agents.crowd`: people (:class:`~citygen.runner.agents.crowd.Crowd`)
  walking to their goals and back on walkable ground, avoiding each other and the robot;
- :mod:`~citygen.runner.agents.traffic`: vehicles by the Intelligent Driver Model
  (:class:`~citygen.runner.agents.traffic.Traffic`), and city traffic that obeys signals and
  yields in junctions (:class:`~citygen.runner.agents.traffic.CityTraffic`);
- :mod:`~citygen.runner.agents.lanes`: the paths vehicles drive through their route of blocks;
- :mod:`~citygen.runner.agents.signals`: signal states in time, crosswalks and the roadway,
  and people who wait for *walk*;
- :mod:`~citygen.runner.agents.footprints`: vehicles' footprints as people see them (the
  discs covering them, how deep a disc reaches into one);
- :mod:`~citygen.runner.agents.vec2`: 2-D vector helpers.

The submodules are imported where they are used (a scene without agents needs none of them).
"""
