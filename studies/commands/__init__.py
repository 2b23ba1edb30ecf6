"""The commands, each a function with typed settings that returns a result and, given ``out=``,
writes the same folder as the ``astrocpg`` command of the same name (unit, run, train, power,
evaluate, the trained gait, plot and video), and the Python API over them (``api``: what
``import astrocpg as ac`` gives), with the settings they share (``settings``) and the
closed-loop simulation they all run (``simulate``)."""
