"""Reading a tic-tac-toe board from a camera image with OpenCV and numpy.

:mod:`kinegym.vision.board_reader` holds :class:`~vision.board_reader.BoardReader` (finds the grid
in every frame, undoes the perspective, calls each cell empty / X / O with a confidence)
and the seed's baseline :class:`~vision.board_reader.ThresholdReader`. Importing
``vision`` itself loads nothing heavy.
"""
