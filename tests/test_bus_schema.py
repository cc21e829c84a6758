import msgpack
import numpy as np
import pytest

from bus_schema import (Command, Input, PairBatch, Proposal, SchemaError, Status, TrainingPair, decode, encode)
from bus_schema.codec import MAX_PAYLOAD


def test_round_trip_decodes_vectors_without_copy():
    raw = encode(Input(7, 1.25, np.arange(5.0)))
    msg = decode(Input, raw, "dl/a/input", {"x": 5})
    assert msg.tick == 7 and msg.stamp == 1.25
    np.testing.assert_array_equal(msg.x, np.arange(5.0))
    assert msg.x.base is not None  # a view on the payload, not a per-element Python list


def test_optional_vector_may_be_nil():
    msg = decode(Proposal, encode(Proposal(1, "teacher/t", None, 1.0)), "k", {"y": 3})
    assert msg.y is None


def _tamper(msg, **changes):
    data = msgpack.unpackb(encode(msg))
    for k, v in changes.items():
        if v is KeyError:
            del data[k]
        else:
            data[k] = v
    return msgpack.packb(data, use_bin_type=True)


@pytest.mark.parametrize("raw, field, words", [
    (_tamper(Input(1, 0.0, np.zeros(3)), v=2), "v", "unknown schema version 2"),
    (_tamper(Input(1, 0.0, np.zeros(3)), tick=KeyError), "tick", "missing"),
    (encode(Input(1, 0.0, np.zeros(4))), "x", "expected 3 values, got 4"),
    (encode(Input(1, 0.0, np.array([0.0, np.nan, 0.0]))), "x", "value 1 is nan"),
    (encode(Input(1, 0.0, np.array([0.0, 0.0, np.inf]))), "x", "value 2 is inf"),
    (_tamper(Input(1, 0.0, np.zeros(3)), stamp=float("nan")), "stamp", "not finite"),
    (_tamper(Input(1, 0.0, np.zeros(3)), tick="1"), "tick", "expected an integer"),
    (_tamper(Input(1, 0.0, np.zeros(3)), x=b"1234567"), "x", "not a multiple of 8"),
    (b"\xc1garbage", "*", "not a msgpack payload"),
    (msgpack.packb([1, 2]), "*", "expected a msgpack map"),
    (b"\x00" * (MAX_PAYLOAD + 1), "*", "exceeds the limit"),
])
def test_decode_names_key_and_field(raw, field, words):
    with pytest.raises(SchemaError) as err:
        decode(Input, raw, "dl/a/input", {"x": 3})
    assert err.value.key == "dl/a/input" and err.value.field == field
    assert words in str(err.value)


def test_message_checks():
    with pytest.raises(SchemaError, match="confidence"):
        decode(Proposal, encode(Proposal(1, "learner/l", np.zeros(2), 1.5)), "k", {"y": 2})
    with pytest.raises(SchemaError, match="mode"):
        decode(Command, encode(Command(1, 0.0, np.zeros(2), "bored", "x/y", 0.5)), "k", {"y": 2})
    with pytest.raises(SchemaError, match="counters"):
        decode(Status, encode(Status("r", "n", 1, {"a": float("nan")}, {})), "k")
    with pytest.raises(SchemaError, match="rows"):
        decode(PairBatch, encode(PairBatch("e", 1, np.zeros((2, 3)), np.zeros((3, 1)), np.ones((3, 1)))), "k",
               {"x": 3, "y": 1})


def test_pair_batch_rows():
    raw = encode(PairBatch("e", 4, np.ones((3, 2)), np.zeros((3, 1)), np.ones((3, 1))))
    msg = decode(PairBatch, raw, "k", {"x": 2, "y": 1})
    assert msg.x.shape == (3, 2) and msg.y.shape == msg.mask.shape == (3, 1) and msg.first_seq == 4


def test_training_pair_round_trip():
    pair = TrainingPair("ab12", 9, 3, np.ones(2), np.zeros(1), "teacher/t")
    back = decode(TrainingPair, encode(pair), "k", {"x": 2, "y": 1})
    assert (back.epoch, back.seq, back.source) == ("ab12", 9, "teacher/t")


def test_mask_shape_and_values():
    ok = encode(Proposal(1, "teacher/t", np.zeros(3), 1.0, np.array([0.0, 1.0, 0.0])))
    assert list(decode(Proposal, ok, "k", {"y": 3}).mask) == [0, 1, 0]
    with pytest.raises(SchemaError, match="mask"):
        decode(Proposal, encode(Proposal(1, "teacher/t", np.zeros(3), 1.0, np.array([0.0, 0.5, 0.0]))), "k", {"y": 3})
    with pytest.raises(SchemaError, match="expected 3 values, got 2"):
        decode(Proposal, encode(Proposal(1, "teacher/t", np.zeros(3), 1.0, np.zeros(2))), "k", {"y": 3})


def test_reward_and_episode_round_trip_and_refuse_what_cannot_be():
    from bus_schema import Episode, Reward
    reward = decode(Reward, encode(Reward(5, 0, 3, -1.5, -4.0, False)), "dl/a/reward")
    assert (reward.episode, reward.step, reward.episode_return) == (0, 3, -4.0)
    episode = decode(Episode, encode(Episode(2, 200, -130.5, False, True, {"teacher": 150, "student": 50}, 1.0)),
                     "dl/a/episode")
    assert episode.modes == {"teacher": 150, "student": 50} and episode.truncated
    bad = [(Reward(5, -1, 3, 0.0, 0.0, False), "episodes count from 0"),
           (Reward(0, 0, 3, 0.0, 0.0, False), "ticks from 1"),
           (Episode(1, 10, 0.0, True, False, {"pilot": 3}, 1.0), "modes.pilot"),
           (Episode(1, 10, 0.0, True, False, {"teacher": 8, "unsure": 8}, 1.0), "16 steps counted by mode"),
           (Episode(1, 10, 0.0, True, False, {"student": -1}, 1.0), "modes.student")]
    for message, words in bad:
        with pytest.raises(SchemaError, match=words):
            decode(type(message), encode(message), "dl/a/x")


def test_a_learners_backlog_is_a_count_and_absent_means_none():
    sent = decode(Proposal, encode(Proposal(1, "learner/l", np.zeros(2), 0.0, learned=40, backlog=7)), "k", {"y": 2})
    assert (sent.learned, sent.backlog) == (40, 7)
    older = msgpack.packb({"v": 1, "tick": 1, "source": "learner/l", "y": None, "confidence": 0.5, "mask": None})
    assert (decode(Proposal, older, "k").learned, decode(Proposal, older, "k").backlog) == (-1, 0)
    for field, value in (("backlog", -1), ("learned", -2)):
        with pytest.raises(SchemaError, match=field):
            decode(Proposal, encode(Proposal(1, "learner/l", np.zeros(2), 0.0, **{field: value})), "k", {"y": 2})
