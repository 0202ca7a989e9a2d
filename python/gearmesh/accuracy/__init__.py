"""The accuracy of the stiffness levels against the FE reference (`gearmesh accuracy`,
docs/validation.md): the sweeps (sweep), the references (reference), the ISO comparison (iso), the
settings compared (settings), timing (timing), the tables and plots (report); levels runs them."""
