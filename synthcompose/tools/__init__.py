"""Commands on a finished batch: check-placement (check), the HTML report (report), compare-lighting (compare)."""
