"""Every bound class, function and method carries a docstring beyond its signature."""

import inspect

import dronetwin._core as core

def explained(doc, name):
    """pybind11 docstrings start with the signature line(s); text after them is ours."""
    if not doc:
        return False
    lines = [ln for ln in doc.strip().splitlines() if ln.strip()]
    return any(not ln.lstrip().startswith((name + "(", "Overloaded function", "1. ", "2. ")) for ln in lines)


def undocumented(module=core):
    """Names in `module` (the extension, or a submodule such as dronetwin.planning) without one."""
    missing = []
    for cname, obj in vars(module).items():
        if cname.startswith("_"):
            continue
        if inspect.isclass(obj):
            if not explained(obj.__doc__, cname):
                missing.append(cname)
            for mname, member in vars(obj).items():
                # Python protocol methods (__repr__, __copy__, ...) document themselves by name.
                if mname.startswith("_") or not callable(member) or inspect.isclass(member):
                    continue
                if type(member).__name__ not in ("instancemethod", "builtin_function_or_method"):
                    continue
                if not explained(member.__doc__, mname):
                    missing.append(f"{cname}.{mname}")
        elif callable(obj) and not explained(obj.__doc__, cname):
            missing.append(cname)
    return missing


def test_everything_bound_is_documented():
    assert undocumented() == []
