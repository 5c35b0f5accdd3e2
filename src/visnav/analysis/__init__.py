"""visnav.analysis"""
