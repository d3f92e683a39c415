"""A block of a tracker profile's YAML written again, the profile's other
lines kept (the fit scripts: fit_error_model.py, fit_offsets.py,
fit_posture.py)."""
import yaml


def with_block(text, key, values, comment):
    """The profile YAML ``text`` with ``values`` as its ``key`` block (one
    it had, and the comment just above it, replaced) under ``comment``
    (lines, each put after '# '); its other lines as they were."""
    out, skipping = [], False
    for line in text.splitlines(keepends=True):
        if line.startswith(key + ':'):
            while out and out[-1].startswith('#'):
                out.pop()
            skipping = True
        elif skipping and line[:1] not in (' ', '-', '\n'):
            skipping = False
        if not skipping:
            out.append(line)
    return ''.join(out).rstrip('\n') + '\n' + ''.join(
        '# %s\n' % line for line in comment) + \
        yaml.safe_dump({key: values}, default_flow_style=None,
                       sort_keys=False, width=100)
