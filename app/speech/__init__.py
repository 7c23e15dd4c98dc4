"""Who said what: speech recognition of each person's voice (:mod:`app.speech.transcriber`)."""
