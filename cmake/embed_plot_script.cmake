# Turns src/experiments/plots.py into a C++ raw string literal (kPlotScript).
file(READ "${INPUT}" content)
file(WRITE "${OUTPUT}" "// Generated from plots.py; edit that file.\nstatic const char kPlotScript[] = R\"gipdyn_py(${content})gipdyn_py\";\n")
