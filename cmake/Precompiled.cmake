# SPDX-License-Identifier: Apache-2.0
# Build time: parsing the standard, Eigen, TBB and abseil headers (and gRPC and the API's messages
# in the server and the client) took 3 to 5 s of every source's compile, over half of the demo's
# build on two cores. Each is parsed once here, into a precompiled header the libraries reuse
# (they share the compile flags it is built with). tests/CMakeLists.txt does the same for the tests.

add_library(scanprep_pch_core OBJECT ${PROJECT_SOURCE_DIR}/cmake/pch/anchor.cc)
target_include_directories(scanprep_pch_core PRIVATE ${PROJECT_SOURCE_DIR})
target_link_libraries(scanprep_pch_core PRIVATE TBB::tbb Eigen3::Eigen absl::status absl::statusor
  absl::strings absl::str_format)
target_precompile_headers(scanprep_pch_core PRIVATE ${PROJECT_SOURCE_DIR}/cmake/pch/core.h)

# scanprep_precompiled(TARGET... [SERVICE]): the targets compile with the core header, or with
# SERVICE the service one (defined once scanprep_proto exists: scanprep_define_service_pch()).
function(scanprep_precompiled)
  cmake_parse_arguments(PCH "SERVICE" "" "" ${ARGN})
  foreach(target ${PCH_UNPARSED_ARGUMENTS})
    if(PCH_SERVICE)
      target_precompile_headers(${target} REUSE_FROM scanprep_pch_service)
    else()
      target_precompile_headers(${target} REUSE_FROM scanprep_pch_core)
    endif()
  endforeach()
endfunction()

function(scanprep_define_service_pch)
  add_library(scanprep_pch_service OBJECT ${PROJECT_SOURCE_DIR}/cmake/pch/anchor.cc)
  target_include_directories(scanprep_pch_service PRIVATE ${PROJECT_SOURCE_DIR})
  target_link_libraries(scanprep_pch_service PRIVATE scanprep_proto gRPC::grpc++ TBB::tbb
    Eigen3::Eigen absl::status absl::statusor absl::strings absl::str_format absl::time)
  target_precompile_headers(scanprep_pch_service PRIVATE ${PROJECT_SOURCE_DIR}/cmake/pch/service.h)
endfunction()
