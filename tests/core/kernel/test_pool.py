"""The kernel's spare scratch (:func:`dualmech.core.kernel.pool.take_scratch`, ``give_scratch``): a set given
back is taken again, never by two takers, and only so many kinds are kept; the side pool runs beside the
kernel's."""

from __future__ import annotations

import pytest

from dualmech.core.kernel import pool


@pytest.fixture(autouse=True)
def _no_spares(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(pool, "_SPARE", {})


def test_a_set_given_back_is_taken_once() -> None:
    made: list[object] = []

    def make() -> object:
        made.append(object())
        return made[-1]

    first, second = pool.take_scratch("k", make), pool.take_scratch("k", make)
    assert len(made) == 2 and first is not second
    pool.give_scratch("k", [first, second])
    taken = {id(pool.take_scratch("k", make)), id(pool.take_scratch("k", make))}
    assert taken == {id(first), id(second)} and len(made) == 2  # both reused, each by one taker
    assert pool.take_scratch("k", make) is made[-1] and len(made) == 3  # none spare: a new one
    assert pool.take_scratch("other", make) is made[-1] and len(made) == 4  # another kind's are not taken


def test_only_so_many_kinds_and_sets_are_kept() -> None:
    for kind in range(pool.SCRATCH_KINDS + 1):
        pool.give_scratch(kind, [kind])
    assert pool.take_scratch(0, lambda: "new") == "new"  # the least recently given back kind went first
    assert pool.take_scratch(pool.SCRATCH_KINDS, lambda: "new") == pool.SCRATCH_KINDS
    pool.give_scratch("many", range(pool.SCRATCH_SETS + 5))
    assert len(pool._SPARE["many"]) == pool.SCRATCH_SETS


def test_side_work_runs_while_every_kernel_thread_is_busy() -> None:
    """A table's compiled work (``side_pool``) does not queue behind the kernel's blocks: with every kernel
    thread held, it still runs, on threads of its own."""
    import threading

    release = threading.Event()
    held = [pool.kernel_pool().submit(release.wait, 30) for _ in range(pool.threads())]
    try:
        side = pool.side_pool().submit(lambda: threading.current_thread().name)
        assert side.result(timeout=10).startswith("dualmech-side")
        assert not any(block.done() for block in held)
    finally:
        release.set()
    assert all(block.result(timeout=10) for block in held)
