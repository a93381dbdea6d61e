"""Simulated hardware: the drawing board and its camera (OpenCV + numpy), the pymunk models.

* :mod:`kinegym.envs.sim.board` - a canvas in cm on which strokes leave ink; hand-drawn marks.
* :mod:`kinegym.envs.sim.camera` - photographs of the canvas: pose, perspective, light, blur,
  noise, JPEG.
* :mod:`kinegym.envs.sim.scenes` - random photographed boards with their truth (tests, benchmarks).

Submodules are imported on demand.
"""
