// SPDX-License-Identifier: Apache-2.0
// The early returns of abseil's Status flow, which Debian's abseil (20220623) does not ship yet.
#pragma once

#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

// Returns the status of `expr` (an absl::Status) from the enclosing function unless it is OK.
#define SCANPREP_RETURN_IF_ERROR(expr)                                      \
  do {                                                                      \
    if (::absl::Status scanprep_status_ = (expr); !scanprep_status_.ok()) { \
      return scanprep_status_;                                              \
    }                                                                       \
  } while (false)

// `lhs = *expr` for an absl::StatusOr `expr`, or returns its status from the enclosing function.
#define SCANPREP_ASSIGN_OR_RETURN(lhs, expr) \
  SCANPREP_ASSIGN_OR_RETURN_IMPL(SCANPREP_STATUS_CONCAT(scanprep_or_, __LINE__), lhs, expr)
#define SCANPREP_ASSIGN_OR_RETURN_IMPL(tmp, lhs, expr) \
  auto tmp = (expr);                                   \
  if (!tmp.ok()) return std::move(tmp).status();       \
  lhs = *std::move(tmp)
#define SCANPREP_STATUS_CONCAT(a, b) SCANPREP_STATUS_CONCAT_INNER(a, b)
#define SCANPREP_STATUS_CONCAT_INNER(a, b) a##b
