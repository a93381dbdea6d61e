"""Reading a tic-tac-toe board from a camera image with OpenCV (filled by a later issue)."""
