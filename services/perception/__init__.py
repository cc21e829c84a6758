"""Perception: colour blobs in the nose camera's frames, as the paper's ball-seeking input.
Frames are RGB uint8 arrays everywhere in this package (the simulator renders RGB)."""
