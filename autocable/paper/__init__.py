"""The paper's output: every figure (`figures`), the comparison with what Sect. 5 states (`report`)
and with digitised published curves (`compare`)."""
