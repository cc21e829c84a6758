"""The page where a person watches, teaches, corrects and teleoperates the robot (`dogged ui`):
protocol.py checks what the page says, bridge.py and teleop.py are the bus side, server.py serves the
page (static/) and its WebSocket, headless.py opens it in chromium for tests and the benchmark."""
