"""Reading a tic-tac-toe board from a camera image with OpenCV and numpy.

:mod:`kinegym.vision.board_reader` holds :class:`~kinegym.vision.board_reader.BoardReader`
(finds the grid in every frame, undoes the perspective, calls each cell empty / X / O with a
confidence), built from :mod:`~kinegym.vision.ink` (the ink map),
:mod:`~kinegym.vision.grid_lines` (the grid's straight lines) and :mod:`~kinegym.vision.cells`
(cell features and their classification) and :mod:`~kinegym.vision.counts` (the X and O counts
a game can have), with :mod:`~kinegym.vision.hand_grid` for real
hand-drawn '#' grids (wavy, unframed, pale); :mod:`~kinegym.vision.reading` is the result type,
:mod:`~kinegym.vision.debug` draws what the reader did, and
:mod:`~kinegym.vision.threshold_reader` keeps the seed's baseline reader. Importing
``kinegym.vision`` itself loads nothing heavy.
"""
