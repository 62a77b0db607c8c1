"""The one batch runner of the study, the correspondence and the meshing."""

import os

import numba
import threadpoolctl

from ladders.study.batch import run_batch


def threads_seen(i):
    blas = [p["num_threads"] for p in threadpoolctl.threadpool_info() if p["user_api"] == "blas"]
    return i, numba.get_num_threads(), max(blas, default=1)


def test_results_come_in_order_with_the_threads_of_a_lone_run_or_of_a_worker():
    lone = list(run_batch(threads_seen, [(i,) for i in range(3)], jobs=1))
    assert [r[0] for r in lone] == [0, 1, 2]
    assert all(r[1] == numba.config.NUMBA_NUM_THREADS and r[2] == 1 for r in lone)
    cores = os.cpu_count() or 1
    workers = list(run_batch(threads_seen, [(i,) for i in range(4)], jobs=2))
    assert [r[0] for r in workers] == [0, 1, 2, 3]
    assert all(r[1] == max(1, cores // 2) and r[2] == 1 for r in workers)
    assert sorted(r[0] for r in run_batch(threads_seen, [(i,) for i in range(4)], jobs=2,
                                          ordered=False)) == [0, 1, 2, 3]  # fmt: skip


def test_progress_callback_sees_every_result_and_an_empty_batch_yields_nothing():
    seen = []
    out = list(run_batch(threads_seen, [(5,), (6,)], progress=seen.append))
    assert seen == out
    assert list(run_batch(threads_seen, [])) == []


def square_and_record(i, folder):
    """A work function that leaves a trace of each item it ran."""
    (folder / f"{i}.ran").write_text("")
    return ("computed", i * i)


def test_done_items_are_reused_without_running_and_come_first(tmp_path):
    stored = {1: ("stored", 1), 3: ("stored", 9)}
    tasks = [(i, tmp_path) for i in range(5)]
    seen = []
    for jobs in (1, 2):
        out = list(run_batch(square_and_record, tasks, jobs=jobs, progress=seen.append,
                             reuse=lambda i, folder: stored.get(i)))  # fmt: skip
        assert out == [("stored", 1), ("stored", 9), ("computed", 0), ("computed", 4),
                       ("computed", 16)]  # fmt: skip
        assert sorted(p.name for p in tmp_path.glob("*.ran")) == ["0.ran", "2.ran", "4.ran"]
    assert len(seen) == 10
    everything = {i: ("stored", i) for i in range(5)}
    assert list(run_batch(square_and_record, tasks, reuse=lambda i, f: everything[i])) == [
        ("stored", i) for i in range(5)
    ]


def read_relative(path):
    """A work function given a path relative to the caller's folder."""
    with open(path, encoding="utf-8") as fh:
        return fh.read()


def test_relative_paths_mean_the_callers_folder_even_in_reused_workers(tmp_path, monkeypatch):
    for name in ("a", "b"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "item.txt").write_text(name)
    monkeypatch.chdir(tmp_path / "a")
    assert list(run_batch(read_relative, [("item.txt",)] * 4, jobs=2)) == ["a"] * 4
    monkeypatch.chdir(tmp_path / "b")  # the same worker processes are reused
    assert list(run_batch(read_relative, [("item.txt",)] * 4, jobs=2)) == ["b"] * 4
