"""The page (`dogged ui`) as a person sees it: Debian's chromium, headless, driven by Playwright, on
deploy/ballseek.toml brought up by the supervisor (every box a process, real physics). The tests run
in order on one live system; screenshots of each mode go to the run's folder."""
import os
import signal
import time

import cv2
import numpy as np
import pytest

from bus_schema import Proposal, TrainingPair, decode
from rigs.harness import Probe, free_port, needs_chromium, wait_until
from rigs.headless import open_page
from rigs.live.page import start_ballseek_with_page, teach_click_to_bus
from services.own_identities import page_address

pytestmark = [pytest.mark.live, needs_chromium]
UNSURE_BELOW = 0.25  # deploy/ballseek.toml's arbitrator's (its default): below, the student asks


# the page's sound, heard as it is made: headless chromium runs a real AudioContext (with no speaker) and
# has speechSynthesis; this listens to the tones started and the sentences spoken, and lets them through
LISTEN = """
window.__heard = [];
const startTone = OscillatorNode.prototype.start;
OscillatorNode.prototype.start = function (when) {
  window.__heard.push(["tone", this.frequency.value, this.context.state]);
  return startTone.call(this, when);
};
// every object URL the page made and has not revoked (each holds a camera frame's JPEG)
window.__urls = new Set();
const makeUrl = URL.createObjectURL.bind(URL), dropUrl = URL.revokeObjectURL.bind(URL);
URL.createObjectURL = (blob) => { const u = makeUrl(blob); window.__urls.add(u); return u; };
URL.revokeObjectURL = (u) => { window.__urls.delete(u); dropUrl(u); };
if (window.speechSynthesis) {
  const speak = speechSynthesis.speak.bind(speechSynthesis);
  speechSynthesis.speak = (u) => { window.__heard.push(["say", u.text]); speak(u); };
}
"""


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("ui") / "run"
    port = free_port()
    run = start_ballseek_with_page(run_dir, f"tcp/127.0.0.1:{free_port()}", port)
    held, probe = run.record(run.keys.train), Probe(run.endpoint)  # (the subscriber lives while held)
    train = run.recorded[run.keys.train]
    try:
        with open_page(page_address(port, wait_s=30), before=LISTEN) as page:
            page.wait_for_selector("#ears[data-mode]", timeout=30_000)
            yield run, page, train, run_dir, probe
    finally:
        held.undeclare()
        probe.close()
        assert run.close() == 0


def shot(page, run_dir, name):
    path = run_dir / "screens" / f"{name}.png"
    path.parent.mkdir(exist_ok=True)
    page.screenshot(path=str(path), full_page=True)
    print(f"screenshot: {path}")


def ears(page) -> str:
    return page.get_attribute("#ears", "data-mode")


def learner_sure(run, answers: int = 30) -> bool:
    """The learner's last `answers` (2 s at 15 Hz) all sure enough for the student to drive."""
    key = f"{run.keys.prefix}/proposal/learner/*"
    last = run.messages(Proposal, key, max(0, len(run.recorded[key]) - answers))
    return len(last) == answers and all(p.confidence >= UNSURE_BELOW for p in last)


def test_page_loads_and_shows_the_services_and_the_robot_asking(live):
    run, page, _, run_dir, _ = live
    assert "instance main" in page.inner_text("#where")
    wait_until(lambda: page.locator('tr[data-service="main/learner/learner"] td.alive').count() == 1, 10,
               "the learner listed alive")
    for role in ("aibo/aibo", "arbitrator/arbitrator", "teacher/seeker", "perception/perception"):
        assert page.locator(f'tr[data-service="main/{role}"] td.alive').count() == 1, role
    # untaught, the student is unsure: the ears are green and the page asks, with a chime and aloud
    wait_until(lambda: ears(page) == "unsure", 20, "the unsure ears")
    assert "unsure" in page.inner_text("#ears-text")
    heard = wait_until(lambda: len(h := page.evaluate("window.__heard")) >= 3 and h, 5, "the page asking aloud")
    assert [h[:2] for h in heard] == [["tone", 660], ["tone", 880], ["say", "I am unsure. Teach me."]], heard
    assert heard[0][2] == "running", f"the chime's audio context is {heard[0][2]}"
    shot(page, run_dir, "unsure")


def test_frames_that_come_faster_than_they_are_decoded_leave_no_image_behind_and_the_newest_is_shown(live):
    """(issue 31's soak) The page's browser grew 250-300 MB an hour of ball seeking: frames shown as <img>s of
    blob URLs, which headless chromium kept, revoked or not. Frames are drawn on a canvas now, no URL made, and
    of frames decoded out of order the newest stays."""
    _, page, _, _, _ = live
    urls, drawn, last = page.evaluate("""async (jpegs) => {
        const head = hello ? hello.frame_header_bytes : 16;
        const drawn = [], draw = CanvasRenderingContext2D.prototype.drawImage;
        CanvasRenderingContext2D.prototype.drawImage = function (...args) {
            drawn.push(frameDrawn);  // the frame being drawn (the camera's stream goes on meanwhile)
            return draw.apply(this, args);
        };
        for (const jpeg of jpegs) {  // all before the first is decoded
            const frame = new Uint8Array(head + jpeg.length);
            frame.set(jpeg, head);
            onFrame(frame.buffer);
        }
        const last = framesCame;
        await new Promise((done) => setTimeout(done, 500));
        CanvasRenderingContext2D.prototype.drawImage = draw;
        return [window.__urls.size, drawn, last];
    }""", [list(cv2.imencode(".jpg", np.full((60, 80, 3), g, np.uint8))[1].tobytes()) for g in range(10, 210, 10)])
    assert urls == 0, f"{urls} frames' URLs made and left"
    assert last in drawn and drawn == sorted(set(drawn)), f"drawn {drawn}: an older frame over a newer one"


def test_teach_turns_the_ears_to_teacher_within_200_ms_and_the_camera_moves(live):
    run, page, _, run_dir, _ = live
    run.reset_arena(1, {"pink": [1.2, 0.4]})
    time.sleep(1.0)
    latencies = []
    for _ in range(4):  # on and off: the ears turn red each time
        latencies.append(teach_click_to_bus(run, page, "seeker"))
        page.wait_for_selector('button.toggle.on[data-teacher="seeker"]', timeout=5000)
        page.click('button.toggle[data-teacher="seeker"]')
        wait_until(lambda: run.mode() != "teacher", 5, "the teacher off")
        time.sleep(0.5)
    latencies.append(teach_click_to_bus(run, page, "seeker"))
    print(f"click on Teach to the first teacher command on the bus: {[round(ms) for ms in latencies]} ms")
    assert np.median(latencies) < 200
    wait_until(lambda: ears(page) == "teacher", 2, "the page's ears red")
    before = page.locator("#camera").screenshot()
    wait_until(lambda: page.locator("#camera").screenshot() != before, 5, "the camera image to change")
    frames = page.evaluate("window.doggedStats.frames.length")
    assert frames >= 20, f"{frames} frames shown"
    shot(page, run_dir, "teacher")
    # teach until the student is sure of this arena, then let it drive
    wait_until(lambda: learner_sure(run), 90, "the learner sure of the last 2 s the teacher drove")
    page.click('button.toggle[data-teacher="seeker"]')
    wait_until(lambda: ears(page) in ("student", "unsure"), 5, "the teacher off")
    run.reset_arena(1, {"pink": [1.2, 0.4]})
    wait_until(lambda: ears(page) == "student", 30, "the student driving")
    shot(page, run_dir, "student")


def test_holding_the_up_arrow_walks_the_robot_and_teaches_the_learner(live):
    run, page, train, _, probe = live
    run.reset_arena(2, {"pink": None, "orange": None})
    time.sleep(1.0)
    first_state = len(run.recorded[run.robot.state])
    pairs_before, learned_before = len(train), probe.counter("learner/learner", "learned")
    page.focus("body")
    page.keyboard.down("ArrowUp")
    time.sleep(4.0)
    assert page.get_attribute("#key-up", "class").endswith("held")
    page.keyboard.up("ArrowUp")
    time.sleep(0.5)
    # forward progress along the way (the student, turning as it searches for a ball, makes it a curve):
    # each step's displacement along the heading, so the gait's sway cancels out
    base = np.array([state.base for state in run.states(first_state)])
    step, yaw = np.diff(base[:, :2], axis=0), base[:-1, 2]
    moved = float(np.sum(step[:, 0] * np.cos(yaw) + step[:, 1] * np.sin(yaw)))
    mine = [decode(TrainingPair, raw, k) for k, raw, _ in train[pairs_before:]]
    mine = [p for p in mine if p.source == "teacher/person"]
    print(f"the up arrow held 4 s: the robot walked {moved:.2f} m forward; {len(mine)} training pairs from the person")
    assert moved > 0.3  # 0.15 m/s for 4 s, less the start and the stop
    assert len(mine) >= 40  # 15 Hz for 4 s
    assert all(np.isclose(p.y[0], 0.15) and p.mask is not None and list(p.mask) == [1.0, 0.0] for p in mine), \
        "forward at full speed, the turn left to the student (a partial teacher)"
    wait_until(lambda: probe.counter("learner/learner", "learned") >= learned_before + len(mine), 10,
               "the learner learned them")


def person_pairs(train, since: int) -> list:
    pairs = (decode(TrainingPair, raw, k) for k, raw, _ in train[since:])
    return [p for p in pairs if p.source == "teacher/person"]


def teaching_now(run) -> list[str]:
    return sorted(str(r.ok.key_expr).rsplit("/", 1)[-1]
                  for r in run.session.liveliness().get(run.keys.teaching("*"), timeout=1) if r.ok)


def test_the_on_screen_left_arrow_teaches_only_the_turn(live):
    run, page, train, _, _ = live
    since = len(train)
    page.locator("#key-left").hover()
    page.mouse.down()
    time.sleep(2.0)
    page.mouse.up()
    mine = person_pairs(train, since)
    print(f"the on-screen left arrow held 2 s: {len(mine)} pairs from the person")
    assert len(mine) >= 20
    assert all(np.isclose(p.y[1], 0.8) and list(p.mask) == [0.0, 1.0] for p in mine), "turn left only"
    wait_until(lambda: "person" not in teaching_now(run), 5, "the person let go")


def test_a_gamepad_stick_drives_and_teaches(live):
    run, page, train, _, _ = live
    time.sleep(0.5)  # the last pairs of the arrows before (lossless, decided up to a deadline later) are in
    since = len(train)
    # a pad as the Gamepad API shows one: stick up (axis 1 negative) half the way from its dead zone's edge, no turn
    page.evaluate("""() => { window.padAxes = [0.0, -0.575];
        Object.defineProperty(navigator, 'getGamepads', {configurable: true,
            value: () => [{id: 'test pad', axes: window.padAxes}]}); }""")
    try:
        wait_until(lambda: len(person_pairs(train, since)) >= 20, 10, "20 pairs from the stick")
        assert "test pad" in page.inner_text("#gamepad")
    finally:
        page.evaluate("() => { window.padAxes = [0.0, 0.0]; }")
    mine = person_pairs(train, since)
    # a stick is one control: straight up, it says both, no turn taught as 0 (not left to the student)
    assert all(np.isclose(p.y[0], 0.075) and np.isclose(p.y[1], 0.0) and p.mask is None for p in mine), \
        "half forward, no turn"
    # just past the dead zone (0.15 of the throw) a stick says a gentle turn, not none: 0.05 of the throw past it
    since = len(train)
    page.evaluate("() => { window.padAxes = [-0.1925, -0.575]; }")
    wait_until(lambda: any(np.isclose(p.y[1], 0.04) for p in person_pairs(train, since)), 10, "a gentle left turn")
    page.evaluate("() => { window.padAxes = [0.1, -0.1]; }")  # inside the dead zone on both axes: let go
    wait_until(lambda: "person" not in teaching_now(run), 5, "the stick at rest: the person let go")
    wait_until(lambda: "person" not in teaching_now(run), 5, "the stick centred: the person let go")


def test_hold_to_teach_teaches_while_pressed(live):
    run, page, _, _, _ = live
    page.locator('button.hold[data-teacher="seeker"]').hover()
    page.mouse.down()
    try:
        wait_until(lambda: teaching_now(run) == ["seeker"], 5, "the seeker teaching while held")
        wait_until(lambda: run.mode() == "teacher", 5, "teacher commands")
        time.sleep(1.0)
        assert teaching_now(run) == ["seeker"], "still teaching while the button is held"
    finally:
        page.mouse.up()
    wait_until(lambda: teaching_now(run) == [], 5, "the seeker off once released")


def test_the_arena_is_reset_with_the_ball_where_the_person_puts_it(live):
    run, page, _, _, _ = live
    since = len(run.recorded[run.robot.state])
    page.fill("#arena-seed", "5")
    page.fill("#pink-x", "0.8")
    page.fill("#pink-y", "-0.2")
    page.click("#arena button[type=submit]")
    wait_until(lambda: any(np.allclose(s.balls["pink"][:2], [0.8, -0.2], atol=0.05) for s in run.states(since)), 10,
               "the pink ball at (0.8, -0.2)")


def test_recording_is_paused_and_resumed_from_the_page(live):
    _, page, _, _, probe = live
    page.wait_for_selector("#record.on", timeout=10_000)  # a recorder runs, recording
    page.click("#record")
    wait_until(lambda: probe.state("recorder/recorder", "recording") is False, 10, "the recorder paused")
    paused = probe.counter("recorder/recorder", "paused_samples")
    wait_until(lambda: probe.counter("recorder/recorder", "paused_samples") > paused + 100, 10, "samples not written")
    page.wait_for_selector("#record:not(.on)", timeout=5000)
    page.click("#record")
    wait_until(lambda: probe.state("recorder/recorder", "recording") is True, 10, "the recorder recording again")
    recorded = probe.counter("recorder/recorder", "recorded")
    wait_until(lambda: probe.counter("recorder/recorder", "recorded") > recorded + 100, 10, "samples written again")


def test_a_learner_killed_shows_gone_then_back(live):
    run, page, _, _, _ = live
    pid = run.ps()["learner"]["pid"]
    os.kill(pid, signal.SIGKILL)
    row = 'tr[data-service="main/learner/learner"]'
    wait_until(lambda: page.locator(f"{row} td.gone").count() == 1, 15, "the learner shown gone")
    wait_until(lambda: page.locator(f"{row} td.alive").count() == 1, 90, "the learner shown back")
    assert run.ps()["learner"]["pid"] != pid


@pytest.mark.parametrize("raw, reason", [
    ("{not json", "not JSON"),
    ('{"op": "teach", "teacher": "seeker", "on": "yes"}', "true or false"),
    ('{"op": "teleop", "y": [NaN, 0]}', "not a number JSON allows"),
    ('{"op": "teleop", "y": [1e309, 0]}', "in [-1, 1]"),
    ('{"op": "teleop", "y": [5, 0]}', "in [-1, 1]"),
    ('{"op": "arena", "seed": 1, "balls": {"<script>": [0, 0]}}', "lowercase"),
    ('{"op": "launch", "what": "missiles"}', "not one of"),
    ('{"op": "ping", "pad": "' + "x" * 5000 + '"}', "at most 4096"),
])
def test_a_malformed_message_shows_an_error_and_changes_nothing(live, raw, reason):
    run, page, _, _, _ = live
    commands = len(run.recorded[run.keys.command])
    teaching = run.session.liveliness().get(run.keys.teaching("*"), timeout=1)
    before = sorted(str(r.ok.key_expr) for r in teaching if r.ok)
    errors = page.locator(".msg.error").count()
    page.evaluate("raw => window.doggedSendRaw(raw)", raw)
    wait_until(lambda: page.locator(".msg.error").count() > errors, 5, "an error on the page")
    assert reason in page.locator(".msg.error").last.inner_text()
    after = sorted(str(r.ok.key_expr) for r in run.session.liveliness().get(run.keys.teaching("*"), timeout=1) if r.ok)
    assert after == before, "no teacher switched"
    wait_until(lambda: len(run.recorded[run.keys.command]) > commands + 10, 5, "the loop goes on")
    assert page.inner_text("#link") == "online"


def test_the_page_fits_a_phone(live):
    _, page, _, run_dir, _ = live
    page.set_viewport_size({"width": 390, "height": 844})
    try:
        page.wait_for_timeout(300)
        shot(page, run_dir, "phone")
        width = page.evaluate("document.documentElement.scrollWidth")
        assert width <= 390, f"the page is {width} px wide on a 390 px screen: it scrolls sideways"
        for arrow in ("up", "left", "down", "right"):  # the on-screen arrows, for thumbs
            box = page.locator(f"#key-{arrow}").bounding_box()
            assert box["width"] >= 44 and box["height"] >= 44 and box["x"] + box["width"] <= 390, (arrow, box)
    finally:
        page.set_viewport_size({"width": 1100, "height": 1300})


def test_the_learner_is_hot_swapped_from_the_page(live):
    run, page, _, _, _ = live
    page.select_option("#swap-service", "learner")
    page.fill("#swap-spec", "knn")
    page.click("#swap button[type=submit]")
    answer = page.locator(".msg.info", has_text="serves in place of")
    answer.wait_for(timeout=120_000)
    print(f"the supervisor answered the page: {answer.first.inner_text()!r}")
    new = answer.first.inner_text().split(" ")[0]
    wait_until(lambda: page.locator(f'tr[data-service="main/learner/{new}"] td.alive').count() == 1, 15,
               f"{new} listed alive")
    assert run.ps()[new]["state"] == "ready"


def test_the_ui_killed_and_restarted_the_open_page_reconnects(live):
    """(last: the ui restarts.) Before issue 31's soak found it, a restarted ui made a new token and the open
    page was refused (401) every second for as long as it stayed open."""
    run, page, _, _, _ = live
    pid = run.ps()["ui"]["pid"]
    os.kill(pid, signal.SIGKILL)
    wait_until(lambda: page.text_content("#link") == "offline", 15, "the page offline")
    wait_until(lambda: page.text_content("#link") == "online", 90, "the page online again")
    wait_until(lambda: ears(page) in ("teacher", "student", "unsure"), 30, "the ears shown again")
    assert run.ps()["ui"]["pid"] != pid
