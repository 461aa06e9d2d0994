//! Cross-crate tests of skeletrace; the tests themselves live in `tests/tests/`.
