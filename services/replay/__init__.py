"""A recorded run used again (services.recording reads it): learners retrained on it and compared
offline (replay, compare: `dogged replay`), its inputs published into a live bus in place of the platform
(`dogged play`, the platform box with the recorded platform); cli.py holds both verbs."""
