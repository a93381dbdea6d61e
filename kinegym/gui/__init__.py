"""kinegym's interactive windows (``kinegym gui climber``, ``kinegym gui arm``), on pygame-ce.

Nothing here is imported by ``import kinegym`` or by the envs; pygame itself is imported only
when a window opens (:func:`kinegym.gui.window.pygame_or_hint`), so a missing toolkit is a
one-line install hint. Apps draw their frames with OpenCV (:mod:`kinegym.gui.widgets`), so
tests drive them with synthetic events and check their state and a screenshot.
"""
