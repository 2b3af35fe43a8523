"""Config fragments the tests share: the paper's stick and its measured geometry."""

#: The stick of the paper: a cylinder R = 7.5, l1 = 348 mm with a 60 mm conical tip.
PAPER_STICK = """\
[stick]
shape = "cylinder-cone"
length_mm = 348
tip_mm = 60
radius_mm = 7.5
"""
