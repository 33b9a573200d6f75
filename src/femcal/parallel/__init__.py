"""Parallel work behind one interface, :class:`concurrent.futures.Executor`: serial, threads
or processes here, and any engine that offers the same interface (see
:mod:`femcal.parallel.executors`)."""

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
    "Kind",
    "ProcessPool",
    "SerialExecutor",
    "die_with_parent",
    "executor",
    "in_background",
    "message_queue",
    "ordered",
    "usable_cores",
]
