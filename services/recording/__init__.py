"""Recording runs: every sample of the bus into MCAP files (writer), read back and repaired (reader),
retrained and compared offline (replay), published again into a live bus (play)."""
