"""The CPG joined to the robot: the project's Unitree A1 model for MuJoCo (``robot``), the 1 ms
bridge between the Brian2 network and the physics, one ``network_operation`` per step (torques
out, senses and reward in: ``bridge``), the world made physical (slopes, terrain, friction,
pushes: ``world``), the closed loop assembled once (``assembly``), the training sessions run
inside that loop (``training``), the recording of chosen sessions (``recorder``) and the
offscreen replay of a recorded run (``render``). It builds on ``network`` and ``models``; the
experiments in ``studies`` build on it."""
