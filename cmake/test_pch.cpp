// The translation unit that compiles the test sources' precompiled header
// (penumbra_test_pch, cmake/PenumbraWarnings.cmake).
