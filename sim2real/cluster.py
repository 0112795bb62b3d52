"""Many logs at once: glob expansion, per-log work as Ray tasks, fleet summaries.

The per-log work is the library's own (:func:`sim2real.agreement.study.run_study` for ``agree``); this
module only fans it out. Without Ray (``address=None``) the same function runs in a plain loop,
so the serial and the Ray paths give identical figures. Ray is the optional ``[cluster]`` extra.

``address``:

- ``"auto"``: join the Ray cluster this machine belongs to (``ray start --head`` ran here, or
  ``RAY_ADDRESS`` is set); when none is running (also when Ray's record of one names a port
  nobody listens on any more, a killed Ray's leftover), start a local one;
- ``"HOST:PORT"`` / ``"ray://HOST:10001"``: that cluster's head node.

Examples
--------
>>> from sim2real.cluster import map_tasks
>>> map_tasks(abs, [-1, 2, -3])          # no address: a plain loop, results in input order
[1, 2, 3]
"""

from __future__ import annotations

import contextlib
import glob
import importlib.util
import inspect
import math
import os
import socket
import threading
import time
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
from threadpoolctl import threadpool_limits

from robots.spec import load_spec
from robots.units import NS_PER_S, nanoseconds
from sim2real.agreement.study import run_study
from sim2real.errors import (
    ClusterLostWarning,
    Sim2RealError,
    Sim2RealFileNotFoundError,
    Sim2RealValueError,
)
from sim2real.logs import write_velocity_log
from sysid.synthetic import step_commands, synthetic_log

__all__ = [
    "agree_many",
    "connect",
    "expand_logs",
    "fleet_summary",
    "guided_batches",
    "map_tasks",
    "write_synthetic_fleet",
]

T = TypeVar("T")
R = TypeVar("R")


def expand_logs(patterns: Sequence[str | Path], *, what: str = "LOG") -> list[Path]:
    """Paths and shell globs (``logs/*.mcap``, ``runs/**/*.bag``) as a sorted, de-duplicated list.

    A glob that matches nothing, or a plain path that does not exist, is refused naming it.

    Examples
    --------
    >>> expand_logs(["data/demo_*.mcap"])  # doctest: +SKIP
    [PosixPath('data/demo_train.mcap'), PosixPath('data/demo_validate.mcap')]
    """
    out: list[Path] = []
    for pattern in patterns:
        text = str(pattern)
        if glob.has_magic(text):
            hits = sorted(glob.glob(text, recursive=True))
            if not hits:
                raise Sim2RealFileNotFoundError(
                    f"{what} pattern '{text}' matches no file; check the folder and the pattern "
                    "(quote it so the shell does not expand it first)"
                )
            out.extend(Path(h) for h in hits)
        else:
            out.append(Path(text))
    seen: set[Path] = set()
    unique = []
    for p in out:
        key = p.resolve()
        if key not in seen:
            seen.add(key)
            unique.append(p)
    return unique


def connect(address: str, *, local_cpus: int | None = None, lean: bool = False) -> bool:
    """Initialise Ray for ``address`` (``auto`` or a head node); no-op when already initialised.

    Returns True when this call started a local Ray (``auto`` with none running), which then
    gets ``local_cpus`` CPUs (default: every core). ``lean=True`` starts such a local Ray
    without the head's cluster services that one command's tasks never use (see
    :func:`_lean_head`); a cluster that is joined is never changed.

    A local Ray started here runs without the dashboard and without usage reporting (background
    work that would otherwise take CPU from the tasks on a small machine), and its workers at
    this process's scheduling priority: Ray's default (``RAY_worker_niceness`` 15) runs every
    task at nice 15, so on a machine doing anything else the per-log tasks get only a fraction
    of the CPU the serial loop gets. An explicit ``RAY_worker_niceness`` in the environment is
    kept.

    Call it from the main thread: Ray ties the processes it starts to the life of the calling
    *thread* (Linux ``PR_SET_PDEATHSIG``, prctl(2)), so a local Ray started from a thread that
    ends dies with it.
    """
    ray = _import_ray(address)
    if ray.is_initialized():
        return False
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    # Ray applies RAY_worker_niceness as an increment (os.nice) to the niceness its workers
    # inherit from the local raylet, which inherits this process's: 0 keeps the caller's
    # priority (an absolute value here doubled it under `nice -n 5`: workers ran at 10).
    os.environ.setdefault("RAY_worker_niceness", "0")
    kw: dict[str, Any] = {"include_dashboard": False, "logging_level": "ERROR"}
    if address == "auto" and not os.environ.get("RAY_ADDRESS") and _stale_cluster_file():
        # Ray would still read the dead record and refuse num_cpus ("connecting to an existing
        # cluster"); a new local Ray writes its own
        _cluster_file().unlink(missing_ok=True)
        with _lean_head(ray, lean) as leaner:
            ray.init(num_cpus=local_cpus, **kw, **_lean_init_kw(leaner))
        return True
    if address == "auto":
        try:
            ray.init(address="auto", **kw)
            return False
        except ConnectionError:  # none running: a local one on this machine
            os.environ.pop("RAY_ADDRESS", None)
            with _lean_head(ray, lean) as leaner:
                ray.init(num_cpus=local_cpus, **kw, **_lean_init_kw(leaner))
            return True
    try:
        ray.init(address=address, **kw)
    except (ConnectionError, ValueError, RuntimeError) as exc:
        raise Sim2RealValueError(
            f"--ray {address}: cannot connect to a Ray cluster there ({' '.join(str(exc).split())}); "
            f"give the head node's HOST:PORT (see `ray status` on it) or 'auto'{_auth_hint()}"
        ) from None
    return False


def _auth_hint() -> str:
    """The part of a connection error about Ray's token authentication (empty when set).

    A head started by Ray 2.60 (``ray start --head``) requires a token; a driver given the
    head's address sends one only with ``RAY_AUTH_MODE=token`` (Ray enables it by itself for
    ``auto`` alone), and is otherwise refused with nothing but "Failed to connect".
    """
    if os.environ.get("RAY_AUTH_MODE"):
        return ""
    return (
        "; if the head uses token authentication (Ray's default for `ray start --head`), set "
        "RAY_AUTH_MODE=token and give this machine the head's token (`ray get-auth-token` on "
        "the head, into ~/.ray/auth_token or RAY_AUTH_TOKEN)"
    )


def _lean_init_kw(lean: bool) -> dict[str, Any]:
    """Extra ``ray.init`` arguments of a local Ray started lean (none otherwise).

    ``prestart_worker_first_driver`` off: by default the raylet starts a worker as the first
    driver registers and holds that driver's registration reply until the worker has
    registered too (``WorkerPool::RegisterDriver``, Ray 2.60), ~0.4 s of ``import ray`` in the
    new process. The driver waits for it inside the ``CoreWorker`` constructor without
    releasing the GIL, so this process's thread, already working on items, would stand still
    for that time. Without it the worker starts with the first task, about as early:
    :func:`map_tasks` submits one right after ``ray.init`` returns.
    """
    return {"_system_config": {"prestart_worker_first_driver": False}} if lean else {}


@contextlib.contextmanager
def _lean_head(ray: Any, lean: bool) -> Iterator[bool]:
    """While a local Ray starts, leave out three head services one command never uses.

    A head started by ``ray.init()`` runs, beside the GCS and the raylet, five Python
    services; three of them serve a long-lived cluster, not one command's tasks: the
    autoscaler monitor (adds nodes), the log monitor (streams workers' stdout/stderr to the
    driver; our tasks return their warnings as values) and the dashboard's API server (job
    submission, state API). Each imports Ray as it starts, and stopping the monitor makes
    ``ray.shutdown()`` wait 1 s (its SIGTERM handler reports to a GCS already stopped, and Ray
    waits 1 s before SIGKILL; Ray 2.60).

    ``ray start`` has switches for the first two (``--no-monitor``,
    ``--include-log-monitor=false``) but ``ray.init()`` has none, so this sets the same
    fields of Ray's private ``RayParams`` and skips ``Node.start_api_server`` for the duration
    of the ``with`` block. Where this Ray's internals differ (another version), it yields
    False and Ray starts as usual. Yields whether the lean start applies.

    It also makes ``ray.init`` notice the new node as soon as it registers
    (:func:`_registered_first`) instead of on Ray's next 1 s poll.
    """
    try:
        from ray._private import node as ray_node
        from ray._private import parameter as ray_parameter
        from ray._private import services as ray_services
    except ImportError:  # pragma: no cover - another Ray layout
        yield False
        return
    params_cls = getattr(ray_parameter, "RayParams", None)
    node_cls = getattr(ray_node, "Node", None)
    fields = ("no_monitor", "include_log_monitor")
    if (
        not lean
        or params_cls is None
        or node_cls is None
        or not hasattr(node_cls, "start_api_server")
        or not all(f in inspect.signature(params_cls.__init__).parameters for f in fields)
    ):
        yield False
        return
    original_init = params_cls.__init__
    original_api = node_cls.start_api_server

    def init(self: Any, *args: Any, **kwargs: Any) -> None:
        original_init(self, *args, **kwargs)
        self.no_monitor = True
        self.include_log_monitor = False

    def no_api_server(self: Any, **kwargs: Any) -> None:
        return None

    params_cls.__init__ = init
    node_cls.start_api_server = no_api_server
    original_get_node = getattr(ray_services, "get_node", None)
    if original_get_node is not None:
        ray_services.get_node = _registered_first(original_get_node)
    try:
        yield True
    finally:
        params_cls.__init__ = original_init
        node_cls.start_api_server = original_api
        if original_get_node is not None:
            ray_services.get_node = original_get_node


#: Seconds between two looks at whether the new local raylet has registered with the GCS.
_REGISTERED_POLL_S = 0.02
#: Longest wait for that registration before leaving it to Ray's own wait (Ray's is 30 s).
_REGISTERED_WAIT_S = 30.0


def _registered_first(get_node: Callable[[str, str], Any]) -> Callable[[str, str], Any]:
    """Ray's ``services.get_node``, called once the node is registered with the GCS.

    A starting local Ray's ``ray.init`` asks the GCS for its new node 0.1 s after starting the
    raylet, and when the node is not there yet, asks again after 1 s, and again
    (``GlobalStateAccessor::GetNode``, a 1 s sleep; Ray 2.60). The raylet registers only once
    its two agents (the dashboard agent and the runtime-env agent, Python processes that
    import Ray) are up, seconds after the start on a small machine, so ``ray.init`` would go
    on up to a second after the node is ready, while nothing can run on it. This asks every
    :data:`_REGISTERED_POLL_S` (one GCS query for that node id) and then lets Ray's call find
    the node at once. An error of the asking (another Ray's API) leaves the wait to Ray.
    """

    def wait_then_get(gcs_address: str, node_id: str) -> Any:
        try:
            raylet: Any = importlib.import_module("ray._raylet")
            gcs_pb2: Any = importlib.import_module("ray.core.generated.gcs_pb2")
            service_pb2: Any = importlib.import_module("ray.core.generated.gcs_service_pb2")
            client = raylet.GcsClient(address=gcs_address)
            node = raylet.NodeID.from_hex(node_id).binary()
            selector = [service_pb2.GetAllNodeInfoRequest.NodeSelector(node_id=node)]
            deadline = time.monotonic() + _REGISTERED_WAIT_S
            while time.monotonic() < deadline and not client.get_all_node_info(
                timeout=_REGISTERED_WAIT_S,
                node_selectors=selector,
                state_filter=gcs_pb2.GcsNodeInfo.GcsNodeState.ALIVE,
            ):
                time.sleep(_REGISTERED_POLL_S)
        except Exception:  # another Ray's API: Ray's own wait still follows
            pass
        return get_node(gcs_address, node_id)

    return wait_then_get


#: Seconds to wait for the GCS port named by Ray's current-cluster file to accept a connection.
_PROBE_S = 0.5


def _stale_cluster_file() -> bool:
    """Whether Ray's record of "the cluster on this machine" names a GCS that is not there.

    ``ray start`` / ``ray.init()`` write the head's ``HOST:PORT`` to :func:`_cluster_file`; a
    Ray that was killed (or a machine that rebooted) leaves it behind, and
    ``ray.init(address="auto")`` then waits for that GCS without end (retrying every 5 s). A
    port that refuses a TCP connection (or a record that is not ``HOST:PORT``) means nobody is
    running there: ``--ray auto`` removes the record and starts a local Ray, as it does when no
    record exists. A probe that only times out (:data:`_PROBE_S`) is left to Ray.
    """
    try:
        host, _, port = _cluster_file().read_text(encoding="utf-8").strip().rpartition(":")
        with socket.create_connection((host, int(port)), timeout=_PROBE_S):
            return False
    except (ConnectionRefusedError, ValueError):
        return True
    except OSError:  # no record (ray.init fails fast, handled by the caller), or a timeout
        return False


def _cluster_file() -> Path:
    """Ray's record of the cluster on this machine (``$RAY_TMPDIR/ray/ray_current_cluster``)."""
    return Path(os.environ.get("RAY_TMPDIR", "/tmp")) / "ray" / "ray_current_cluster"


def _import_ray(address: str) -> Any:
    """The ``ray`` module, or the one-sentence error naming the extra to install."""
    try:
        import ray
    except ImportError:
        raise Sim2RealValueError(
            f"--ray {address} needs Ray, which is not installed; install the cluster extra with "
            "`pip install -e '.[cluster]'` or drop --ray"
        ) from None
    return ray


def _cores() -> int:
    """The cores this process may run on (its CPU affinity where the OS says)."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def guided_batches(n: int, workers: int) -> list[range]:
    """Split ``n`` items into consecutive batches of decreasing size for ``workers`` workers.

    Guided self-scheduling (Polychronopoulos & Kuck, IEEE Trans. Comput. 36(12), 1987): each
    batch takes ``ceil(remaining / (2 * workers))`` items, so the first batches are large (few
    tasks: little scheduling, start-up and result-transfer overhead per item) and the last ones
    single items (the workers finish together). Taken in order by whichever worker is free.

    Examples
    --------
    >>> [len(b) for b in guided_batches(20, 2)]
    [5, 4, 3, 2, 2, 1, 1, 1, 1]
    >>> guided_batches(3, 4)
    [range(0, 1), range(1, 2), range(2, 3)]
    """
    if n < 0 or workers < 1:
        raise Sim2RealValueError(
            f"guided_batches needs n >= 0 and workers >= 1, got n={n}, workers={workers}"
        )
    out = []
    start = 0
    while start < n:
        size = max(1, math.ceil((n - start) / (2 * workers)))
        out.append(range(start, start + size))
        start += size
    return out


def map_tasks(
    fn: Callable[[T], R],
    items: Sequence[T],
    *,
    address: str | None = None,
    on_done: Callable[[int], None] | None = None,
    release: bool = False,
) -> list[R]:
    """``[fn(x) for x in items]``, as Ray tasks when ``address`` is given.

    On Ray, this process works too: a thread takes the items one at a time from the start,
    while the main thread connects to Ray (starting a local one takes seconds) and then hands
    the rest out to Ray tasks, one CPU each, in :func:`guided_batches` sizes for the cluster's
    CPUs plus this process: a task carries several items while many remain and one at the end,
    so all finish together. A local Ray started here gets one core less than the machine has
    (this process's thread uses it) and starts lean (:func:`_lean_head`). ``fn`` is shipped
    once. Results come back in the order of ``items``, the same as the plain loop's. A failing
    item's exception is re-raised as itself (e.g. a bad log's one-sentence error) once the
    running work has stopped; no new work starts after a failure. ``on_done(n)`` is called as
    items finish (progress; from either thread, never concurrently). When Ray itself fails
    (a node or a worker process dies, the cluster stops: any Ray error that is not the item's
    own exception), the items it held and all the rest run in this process, with a
    :class:`~sim2real.errors.ClusterLostWarning`: same results, without the speed-up.
    ``release=True`` shuts
    down a local Ray this call started as soon as its tasks are done (a command that needs Ray
    once: the last items, as many as this process does in the ~0.15 s Ray takes to stop, stay
    for its thread, so the shutdown overlaps them), else it stays up for the next call.

    Examples
    --------
    >>> map_tasks(abs, [-1, 2, -3])
    [1, 2, 3]
    >>> map_tasks(abs, [-1, 2, -3], address="auto")  # doctest: +SKIP
    [1, 2, 3]
    """
    items = list(items)
    if address is None:
        results: list[R] = []
        with _one_thread():  # the thread count of a Ray task: same bits
            for x in items:
                results.append(fn(x))
                if on_done is not None:
                    on_done(len(results))
        return results
    if importlib.util.find_spec("ray") is None:
        _import_ray(address)  # raises the one-sentence error before any work starts
    shared = _Shared(len(items), on_done)
    local = threading.Thread(
        target=_work_here, args=(fn, items, shared), name="sim2real-local-share", daemon=True
    )
    local.start()
    started = False
    try:
        started = connect(address, local_cpus=max(1, _cores() - 1), lean=True)
        lost = _work_on_ray(
            _import_ray(address),
            fn,
            items,
            shared,
            leave_s=_RAY_SHUTDOWN_S if release and started else 0.0,
        )
        if lost is not None:
            _carry_on_without_ray(fn, items, shared, address, lost)
    except BaseException as exc:
        shared.halt()
        if isinstance(exc, Exception):  # a Ctrl-C leaves at once (the thread is a daemon)
            local.join()
        raise
    finally:
        if release and started:
            _import_ray(address).shutdown()
    local.join()
    if shared.errors:
        raise shared.errors[min(shared.errors)]
    return shared.results


#: Wall time of ``ray.shutdown()`` of a local Ray started lean (:func:`_lean_head`), s. With
#: ``release``, the last items that this process's thread can do in that time are left to it,
#: so the shutdown overlaps them instead of following them.
_RAY_SHUTDOWN_S = 0.15


class _Shared:
    """Work shared by this process's thread and the Ray tasks: next item, results, errors."""

    def __init__(self, n: int, on_done: Callable[[int], None] | None) -> None:
        self.lock = threading.Lock()
        self.n = n
        self.next = 0
        self.done = 0
        self.results: list[Any] = [None] * n
        self.errors: dict[int, BaseException] = {}
        self.on_done = on_done
        self.local_item_s = math.nan  # the last item's wall time in this process
        self.returned: list[int] = []  # items Ray held when it failed, for this process

    def take(self, workers: int | None = None, *, leave_s: float = 0.0) -> range:
        """The next item (``workers=None``) or guided batch for ``workers``; empty when done.

        ``leave_s``: a batch is refused when this process's thread alone would finish the
        items left within that time (at its last item's pace), so they stay for it. Items
        given back (:meth:`give_back`) come first, to this process only.
        """
        with self.lock:
            if workers is None and self.returned:
                i = self.returned.pop(0)
                return range(i, i + 1)
            left = self.n - self.next
            if workers is not None and left * self.local_item_s <= leave_s:
                return range(self.next, self.next)
            size = 1 if workers is None else max(1, math.ceil(left / (2 * workers)))
            out = range(self.next, self.next + min(size, left))
            self.next = out.stop
            return out

    def halt(self) -> None:
        """No new work from now on."""
        with self.lock:
            self.next = self.n
            self.returned.clear()

    def give_back(self, taken: range) -> None:
        """Items handed out that will not come back (Ray failed): this process takes them."""
        with self.lock:
            if not self.errors:
                self.returned.extend(taken)

    def finish(
        self, taken: range, values: Sequence[Any] | None, error: BaseException | None
    ) -> None:
        """Store a finished item or batch (or its error, which halts), report progress."""
        with self.lock:
            if error is not None:
                self.errors[taken.start] = error
                self.next = self.n
                self.returned.clear()
                return
            assert values is not None and len(values) == len(taken)
            self.results[taken.start : taken.stop] = values
            self.done += len(taken)
            if self.on_done is not None:
                self.on_done(self.done)


def _work_here(fn: Callable[[Any], Any], items: Sequence[Any], shared: _Shared) -> None:
    """This process's share: one item at a time until none is left (a thread)."""
    with _one_thread():
        while taken := shared.take():
            t0 = time.perf_counter()
            try:
                value = fn(items[taken.start])
            except Exception as exc:  # re-raised by map_tasks in the main thread
                shared.finish(taken, None, exc)
                return
            shared.local_item_s = time.perf_counter() - t0
            shared.finish(taken, [value], None)


def _work_on_ray(
    ray: Any,
    fn: Callable[[Any], Any],
    items: Sequence[Any],
    shared: _Shared,
    *,
    leave_s: float = 0.0,
) -> BaseException | None:
    """Hand the items left out to Ray tasks, one per cluster CPU at a time, until none is left.

    ``leave_s``: see :meth:`_Shared.take` (the last items stay for this process while Ray stops).
    Returns None when every batch came back, or Ray's own error (a dead node or worker, a
    cluster gone) that ended it, the batches still out given back to this process.
    """
    running: dict[Any, range] = {}
    try:
        slots = max(1, int(ray.cluster_resources().get("CPU", 1)))
        remote = ray.remote(num_cpus=1, max_retries=0)(_run_batch)
        fn_ref = None
        while True:
            while len(running) < slots and (taken := shared.take(slots + 1, leave_s=leave_s)):
                if fn_ref is None:
                    fn_ref = ray.put(fn)
                running[remote.remote(fn_ref, [items[i] for i in taken])] = taken
            if not running:
                return None
            ready, _ = ray.wait(list(running), num_returns=1)
            for ref in ready:
                try:
                    values = ray.get(ref)
                except ray.exceptions.RayTaskError as exc:  # the item's own error
                    cause = getattr(exc, "cause", None)
                    error = cause if isinstance(cause, BaseException) else exc
                    shared.finish(running.pop(ref), None, error)
                else:
                    shared.finish(running.pop(ref), values, None)
    except ray.exceptions.RayError as exc:  # Ray's, not an item's: no more of Ray this call
        for taken in running.values():
            shared.give_back(taken)
        return exc


def _carry_on_without_ray(
    fn: Callable[[Any], Any],
    items: Sequence[Any],
    shared: _Shared,
    address: str,
    lost: BaseException,
) -> None:
    """After Ray failed: warn, let go of Ray, and work on the rest in this thread too."""
    ray = _import_ray(address)
    what = " ".join(str(lost).split()).split(". ")[0]
    warnings.warn(
        ClusterLostWarning(
            f"Ray (--ray {address}) failed during the run ({type(lost).__name__}: {what}); "
            f"the {len(shared.returned)} item(s) it held and the rest ran in this process, "
            "with the same results but without the speed-up; check the cluster with "
            "`ray status`"
        ),
        stacklevel=3,
    )
    ray.shutdown()  # not tied to a dead cluster (Ray ends a driver whose GCS stays away)
    _work_here(fn, items, shared)


def _one_thread() -> Any:
    """A context pinning BLAS/OpenMP pools to one thread (threadpoolctl; ~10 ms to enter)."""
    return threadpool_limits(1)


def _run_batch(fn: Callable[[Any], Any], xs: Sequence[Any]) -> list[Any]:
    """``[fn(x) for x in xs]`` with one thread per pool (one Ray task per core)."""
    with _one_thread():
        return [fn(x) for x in xs]


# --------------------------------------------------------------------------- agree


def _study_figures(config: Any) -> tuple[dict[str, Any], tuple[str, ...]]:
    """One log's agreement figures and read warnings (a Ray task; light to ship back).

    A log that cannot be used (unreadable, nothing to compare) gives
    ``{"log_file": path, "error": sentence}`` instead of figures, so the others go on. The
    figures of a log that could be used carry its ``verdict``
    (:meth:`sim2real.agreement.verdict.AgreementVerdict.to_dict`).
    """
    try:
        result = run_study(config)
    except Sim2RealError as exc:
        return {"log_file": str(config.log), "error": str(exc)}, ()
    figures = dict(result.figures)
    if result.verdict is not None:
        figures["verdict"] = result.verdict.to_dict()
    return figures, result.warnings


def agree_many(
    configs: Sequence[Any],
    *,
    address: str | None = None,
    on_done: Callable[[int], None] | None = None,
    release: bool = False,
) -> list[tuple[dict[str, Any], tuple[str, ...]]]:
    """Run :func:`sim2real.agreement.study.run_study` for each config (one per log), serially or on Ray.

    Returns each log's ``(figures, warnings)`` in input order; a log that could not be used
    has ``{"log_file", "error"}`` for figures. ``release``: see :func:`map_tasks`.
    """
    return map_tasks(
        _study_figures, list(configs), address=address, on_done=on_done, release=release
    )


def _finite(values: Sequence[Any]) -> list[float]:
    return [float(v) for v in values if v is not None and math.isfinite(float(v))]


def fleet_summary(figures: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Across logs: agreement pooled over active samples, and its mean / min / max per log.

    With an ensemble (figures holding ``coverage``), the band's ``coverage``, ``coverage_v``
    and ``coverage_w`` are pooled the same way (each log's coverage is a share of its active
    samples), with ``band_level``; ``coverage_mean`` is the plain mean over the logs. Logs
    that could not be used (an ``error`` entry) are counted in ``n_left_out`` only.

    Examples
    --------
    >>> s = fleet_summary([{"log_file": "a", "agreement": 0.8, "agreement_v": 0.9,
    ...                     "agreement_w": 0.85, "n_active": 100},
    ...                    {"log_file": "b", "agreement": 0.5, "agreement_v": 0.6,
    ...                     "agreement_w": 0.7, "n_active": 300}])
    >>> s["agreement"], s["agreement_min"], s["worst_log"]
    (0.575, 0.5, 'b')
    """
    left_out = sum(1 for f in figures if "error" in f)
    figures = [f for f in figures if "error" not in f]
    n_active = [int(f.get("n_active") or 0) for f in figures]
    total = sum(n_active)
    out: dict[str, Any] = {"n_logs": len(figures), "n_active": total, "n_left_out": left_out}
    for key in ("agreement", "agreement_v", "agreement_w"):
        out[key] = _pooled(figures, n_active, key)
    per_log = _finite([f.get("agreement") for f in figures])
    out["agreement_mean"] = sum(per_log) / len(per_log) if per_log else None
    out["agreement_min"] = min(per_log) if per_log else None
    out["agreement_max"] = max(per_log) if per_log else None
    ranked = [f for f in figures if f.get("agreement") is not None]
    out["worst_log"] = (
        min(ranked, key=lambda f: float(f["agreement"])).get("log_file") if ranked else None
    )
    coverage = _finite([f.get("coverage") for f in figures])
    if coverage:
        out["coverage_mean"] = sum(coverage) / len(coverage)
        # pooled like the agreement: each log's coverage is a share of its active samples
        for key in ("coverage", "coverage_v", "coverage_w"):
            out[key] = _pooled(figures, n_active, key)
        out["band_level"] = next(
            f.get("band_level") for f in figures if f.get("coverage") is not None
        )
    return out


def _pooled(figures: Sequence[Mapping[str, Any]], n_active: list[int], key: str) -> float | None:
    """Mean of ``key`` over the logs weighted by their active samples (None when none has it)."""
    pairs = [
        (float(f[key]), n)
        for f, n in zip(figures, n_active, strict=True)
        if f.get(key) is not None and math.isfinite(float(f[key]))
    ]
    weight = sum(n for _, n in pairs)
    return sum(v * n for v, n in pairs) / weight if weight else None


def write_synthetic_fleet(
    folder: str | Path,
    n: int,
    *,
    duration_s: float = 60.0,
    robot: str = "turtlebot3_burger",
    seed: int = 0,
) -> list[Path]:
    """Write ``n`` synthetic sessions (ROS 2 MCAP) of a fleet, for benchmarks and tests.

    Session i drives random step commands (:func:`sysid.synthetic.step_commands`, seed
    ``seed + i``) on the reduced model with the robot's spec parameters, its command delay and
    added mass varied per session, and records degraded odometry
    (:func:`sysid.synthetic.synthetic_log`). Files are ``session_000.mcap``, ...

    Examples
    --------
    >>> paths = write_synthetic_fleet("fleet", 3, duration_s=20.0)  # doctest: +SKIP
    """
    spec = load_spec(robot)
    out = Path(folder)
    paths = []
    for i in range(n):
        rng = np.random.default_rng(seed + i)
        params = spec.drive.replace(
            delay_s=float(rng.uniform(0.05, 0.2)), added_mass_kg=float(rng.uniform(0.0, 0.5))
        )
        t, v, w = step_commands(duration_s, seed=seed + i)
        log = synthetic_log(params, spec.geometry, cmd_t_s=t, cmd_v=v, cmd_w=w, seed=seed + i)
        path = write_velocity_log(
            out / f"session_{i:03d}.mcap",
            cmd_t_ns=nanoseconds(log.cmd_t_s) + NS_PER_S,
            cmd_v=log.cmd_v,
            cmd_w=log.cmd_w,
            meas_t_ns=nanoseconds(log.meas_t_s) + NS_PER_S,
            meas_v=log.meas_v,
            meas_w=log.meas_w,
        )
        paths.append(path)
    return paths
