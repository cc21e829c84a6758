"""What was taught, taken elsewhere: a recorded run as a LeRobot dataset (services.export.lerobot) and its
student as a file (services.export.student; services.learners.student loads it). All of it offline, from
recordings: nothing here runs inside a live service."""
