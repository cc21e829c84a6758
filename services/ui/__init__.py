"""The page where a person watches, teaches, corrects and teleoperates the robot (`dogged ui`):
protocol.py checks what the page says, bridge.py and teleop.py are the bus side, server.py serves the
page (static/) and its WebSocket (rigs/headless.py opens it in chromium for the tests and the benchmark)."""
