"""Parallel work behind one interface, :class:`concurrent.futures.Executor`: serial, threads
or processes here (:mod:`femcal.parallel.executors`), and a Dask cluster for a job's
independent tasks (:mod:`femcal.parallel.cluster`)."""

from .cluster import Engine, Session
from .executors import (
    KINDS,
    Kind,
    ProcessPool,
    SerialExecutor,
    die_with_parent,
    executor,
    in_background,
    message_queue,
    ordered,
    usable_cores,
)

__all__ = [
    "KINDS",
    "Engine",
    "Kind",
    "ProcessPool",
    "SerialExecutor",
    "Session",
    "die_with_parent",
    "executor",
    "in_background",
    "message_queue",
    "ordered",
    "usable_cores",
]
