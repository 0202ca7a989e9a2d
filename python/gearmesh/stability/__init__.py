"""The stability suite (`gearmesh stability`, docs/stability.md): the stiff and extreme cases
(cases), their runs under explicit, implicit and large-step masters (runs), the judged table (suite)
and the gear-train cases (trains)."""
