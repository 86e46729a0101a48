# SPDX-License-Identifier: Apache-2.0
"""Repeating a call the service asked to repeat, within one deadline for all attempts."""

from __future__ import annotations

import dataclasses
import random
import time
from typing import Callable, TypeVar

from scanprep_client.errors import ScanprepError

T = TypeVar("T")


@dataclasses.dataclass(frozen=True)
class RetryPolicy:
    """How often and how long to wait before repeating a retryable call (ScanprepError.retryable).

    The wait is the service's RetryInfo delay when it sent one, else initial_backoff doubled per
    attempt up to max_backoff; either is stretched by a random fraction up to jitter, so that
    clients refused together do not return together. max_attempts=1 never retries."""
    max_attempts: int = 4
    initial_backoff: float = 0.5
    max_backoff: float = 10.0
    jitter: float = 0.2

    def wait(self, error: ScanprepError, attempt: int) -> float:
        """Seconds to wait after the attempt-th (1-based) failed with error."""
        base = error.retry_delay
        if base is None:
            base = min(self.max_backoff, self.initial_backoff * 2 ** (attempt - 1))
        return base * (1 + random.uniform(0, self.jitter))


def call_with_retries(attempt: Callable[[float], T], policy: RetryPolicy, timeout: float) -> T:
    """attempt(seconds left) until it returns, raises what is not retryable, has been tried
    policy.max_attempts times, or would have to wait past the deadline (then at once: the caller
    learns now what waiting could not change)."""
    deadline = time.monotonic() + timeout
    tried = 0
    while True:
        tried += 1
        try:
            return attempt(deadline - time.monotonic())
        except ScanprepError as error:
            if not error.retryable or tried >= policy.max_attempts:
                raise
            wait = policy.wait(error, tried)
            if time.monotonic() + wait >= deadline:
                raise
            time.sleep(wait)
