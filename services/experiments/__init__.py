"""The paper's experiments in one process: Algorithm 2 as a plain loop over the same parts the
services wrap (AiboPlatform, Handler, BlobDetector and its slot layout, the registered teachers
and learners, TeacherFirst), in simulated time as fast as the machine steps it.

    user.py               the person in the loop: a teaching schedule, and answers to unsure requests
    loop.py               one tick of Algorithm 2, and the trace every run records
    evaluate.py           the paper's Figure 5: teacher run on every input the student saw; the PNG
    judges.py             episode outcomes: the nose within 0.2 m of a ball
    mirroring.py          section V.A: one teacher, and two partial teachers in turn
    ballseek.py           section V.B: the ball world (camera, blobs, walking)
    ballseek_protocol.py  section V.B: teaching, student-only episodes, the orange ball
No bus: `benchmarks/experiments.py` prints the figures; `services/demo/` runs ball seeking as
processes over Zenoh (the headline demo), rigs/live the others (the live tests and benchmarks).
"""
