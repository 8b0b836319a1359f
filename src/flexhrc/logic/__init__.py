"""First-order logic for cooperation states (paper 000, eqs. 1-2): terms, variables, literals."""
