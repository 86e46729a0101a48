// SPDX-License-Identifier: Apache-2.0
// What the server, the client and the wire code parse on top of cmake/pch/core.h: gRPC and the
// API's generated messages (regenerated only when proto/ changes).
#pragma once

#include "cmake/pch/core.h"

#include <grpcpp/grpcpp.h>

#include "absl/time/time.h"
#include "scanprep/v1/scanprep.grpc.pb.h"
#include "scanprep/v1/scanprep.pb.h"
