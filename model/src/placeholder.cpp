// The model library grows with the functional core and SystemC issues.
