"""Data from the outside world: prices, weather and solar, gains, forecasts, uncertainty."""
