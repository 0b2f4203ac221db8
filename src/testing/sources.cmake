# The CPU-side harness sources (values, comparison, generators, property tests). Included by
# src/testing/CMakeLists.txt, which adds ${PENUMBRA_TESTING_EXTRA_SOURCES} to penumbra_testing.
set(PENUMBRA_TESTING_EXTRA_SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/values.cpp
    ${CMAKE_CURRENT_LIST_DIR}/compare.cpp
    ${CMAKE_CURRENT_LIST_DIR}/generators.cpp
    ${CMAKE_CURRENT_LIST_DIR}/property.cpp
    ${CMAKE_CURRENT_LIST_DIR}/interval.cpp
    ${CMAKE_CURRENT_LIST_DIR}/interval_functions.cpp
    ${CMAKE_CURRENT_LIST_DIR}/interval_compare.cpp)
