"""Deciding: game players, the gait planner and learned policies (filled by later issues)."""
