"""Physics models (pymunk) and Gymnasium environments of the kinegym robots.

Submodules are imported on demand: ``import envs`` itself loads nothing heavy.
:mod:`kinegym.envs.draw` draws walls and robots headlessly with OpenCV.
"""
