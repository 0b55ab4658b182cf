"""The progress displays: the closed loop's steps bar and the bar of runs / fleet steps."""

from __future__ import annotations

import pytest

from hvacflex.sim.progress import clock_text, progress_bar, task_progress


def test_task_progress_counts_and_shows_its_text() -> None:
    with task_progress(True, "sweep", 4) as update:
        update()
        update(info="1 failed")
        update(completed=4)
        task = update._progress.tasks[0]
        assert task.completed == 4 and task.total == 4
        assert task.fields["info"] == "1 failed"
        assert task.finished
    assert update.completed == 4


def test_disabled_task_progress_still_counts_and_warns_on_stderr(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with task_progress(False, "fleet", 3) as update:
        update()
        update.warn("coordination [at limit]")
    assert update.completed == 1
    assert capsys.readouterr().err == "warning: coordination [at limit]\n"


def test_progress_bar_advances_the_steps_done() -> None:
    bar = progress_bar(True, "rmpc", total=30, done=5)
    with bar as advance:
        for _ in range(20):
            advance()
    assert bar._progress.tasks[0].completed == 25
    with progress_bar(False, "rmpc", total=30, done=0) as quiet:
        assert quiet() is None


def test_stages_count_the_stages_before_the_running_one() -> None:
    with task_progress(True, "bestest", 3) as bar:
        bar.stage("weather")
        assert bar.completed == 0
        bar.stage("case 600")
        bar.stage("case 900")
        task = bar._progress.tasks[0]
        assert task.completed == 2 and task.fields["info"] == "case 900"
    assert task.completed == 3 and task.fields["info"] == "done"


def test_clock_text_reads_minutes_and_hours() -> None:
    assert [clock_text(s) for s in (0, 59.9, 61, 3599, 3600, 5 * 3600 + 62)] == [
        "0:00",
        "0:59",
        "1:01",
        "59:59",
        "1:00:00",
        "5:01:02",
    ]


def test_stages_speak_when_the_output_is_not_a_terminal(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Piped output cannot redraw a bar: each stage is a line of its own, as it starts."""
    with task_progress(True, "identify fit", 2) as bar:
        assert not bar.live  # pytest's captured stdout is no terminal
        bar.stage("reading")
        assert capsys.readouterr().out == "identify fit: [1/2] reading (elapsed 0:00)\n"
        bar.note("a line of its own")
        assert capsys.readouterr().out == "a line of its own\n"
        bar.stage("fitting")
    assert "identify fit: [2/2] fitting (elapsed 0:00)" in capsys.readouterr().out
    with task_progress(False, "quiet", 2) as off:
        off.stage("silent")
        off.beat("silent too")
        off.note("plain")
    assert capsys.readouterr().out == "plain\n"  # quiet: no stage or heartbeat lines


def test_heartbeats_print_at_most_every_heartbeat_s_when_piped(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import hvacflex.sim.progress as progress

    now = [0.0]
    monkeypatch.setattr(progress.time, "perf_counter", lambda: now[0])
    with task_progress(True, "identify fit", 1) as bar:
        for second in (1.0, 5.0, 10.0, 12.0, 21.0):
            now[0] = second
            bar.beat(f"{int(second)} model evaluations")
        assert bar._progress.tasks[0].fields["info"] == "21 model evaluations"
    lines = [line for line in capsys.readouterr().out.splitlines() if "evaluations (" in line]
    assert lines == [
        "identify fit: 10 model evaluations (elapsed 0:10)",
        "identify fit: 21 model evaluations (elapsed 0:21)",
    ]
