"""Recorded runs: every sample of the bus into MCAP files (writer), read back and repaired (reader), a
platform's restarts told apart (restarts), a run as arrays (runs), its inputs played as a platform
(platform: `dogged play`). No bus: the recorder box writes with these, and services.replay reads with them."""
