"""editor.messages is bounded (issue 8): a long session keeps the newest messages only."""

from __future__ import annotations

import copy

from ffd_notebook.view.editor.session.message_log import MAX_MESSAGES, MessageLog


def test_messages_are_bounded_newest_last(editor):
    for n in range(MAX_MESSAGES + 250):
        editor.session.info(f"message {n}")
    assert len(editor.messages) == MAX_MESSAGES
    assert editor.messages[-1] == f"message {MAX_MESSAGES + 249}" and editor.messages[0] == "message 250"
    assert [m for m in editor.messages][-2:] == editor.messages[-2:]  # iterable and sliceable like a list


def test_attempt_still_explains_failures_once_the_log_is_full(editor):
    for n in range(MAX_MESSAGES):
        editor.session.info(f"message {n}")
    assert not editor.session.attempt(int, "not a number")
    assert editor.messages[-1].startswith("Error: invalid literal")
    assert not editor.session.attempt(editor.session.move_control_point, (99, 0, 0), (0.0, 0.0, 1.0))
    assert editor.messages[-1].startswith("Error: control point index") and len(editor.messages) == MAX_MESSAGES
    assert not editor.messages[-2].startswith("Error: control point")  # explained once, not twice


def test_message_log_copies_keep_the_bound():
    log = MessageLog(["a", "b", "c"], maxlen=2)
    assert list(log) == ["b", "c"] and log.n_added == 3
    clone = copy.copy(log)
    assert isinstance(clone, MessageLog) and clone.maxlen == 2 and list(clone) == ["b", "c"]
