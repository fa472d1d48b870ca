"""Design tools: frequency-domain and stability analysis, tuning, controller comparisons."""
