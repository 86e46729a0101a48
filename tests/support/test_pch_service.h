// SPDX-License-Identifier: Apache-2.0
// What the server and client tests parse on top of tests/support/test_pch_core.h: gRPC and the
// API's generated stubs (regenerated only when proto/ changes).
#pragma once

#include <grpcpp/grpcpp.h>

#include "scanprep/v1/scanprep.grpc.pb.h"
#include "scanprep/v1/scanprep.pb.h"
