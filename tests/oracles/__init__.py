"""Reference forms the tests compare the package with, each within a stated tolerance."""
