// SPDX-License-Identifier: Apache-2.0
// Empty: the one source of the libraries' precompiled-header targets (cmake/Precompiled.cmake);
// CMake builds the header with this target's flags.
