"""Growing streets each year: where (nuclei, candidates), what (the era's pattern), and the stubs left in the fields."""
