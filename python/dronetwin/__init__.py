"""dronetwin: Python side of the dronetwin multirotor digital twin (plots for now; the pybind11
bindings arrive as dronetwin._core)."""
