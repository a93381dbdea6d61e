"""Simulated hardware: the drawing board and its camera (OpenCV + numpy), the pymunk models.

* :mod:`envs.sim.board` - a canvas in cm on which strokes leave ink; hand-drawn marks.
* :mod:`envs.sim.camera` - photographs of the canvas: pose, perspective, light, blur,
  noise, JPEG.
* :mod:`envs.sim.scenes` - random photographed boards with their truth (tests, benchmarks).

Submodules are imported on demand.
"""
