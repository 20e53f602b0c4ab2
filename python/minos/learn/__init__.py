"""minos.learn: the reference learner — behaviour cloning (and DAgger) from minos's LeRobot
datasets and evaluation in :class:`minos.gym.VectorNavEnv` (docs/PYTHON.md, "Learning")."""
