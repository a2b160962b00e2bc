// The object that drtv_test_pch compiles its precompiled headers for (tests/CMakeLists.txt).
